"""The firmware on a wired emulated board without the world, for measurements.

``SETUP`` (MicroPython code, run in ``twin.interpreter()``) attaches the
three sensors to the emulated Pico 2, gives them a vehicle at rest just
under the surface, and builds the application (``app.build``) as ``v``;
``task_heap(mp)`` runs its loop until the estimator is valid and returns the
heap bytes one call of each task allocates (``MicroPython.alloc_bytes``:
the collector disabled around one call after a warm-up). Boxed floats are
16 bytes each; the estimator's step is most of ``nav``.
"""

from __future__ import annotations

SETUP = """
import gc, machine, time
from roboray.sim.twin.board import vclock
from roboray.sim.twin.board.ms5837_device import MS5837Device
from roboray.sim.twin.board.lsm6dsox_device import LSM6DSOXDevice
from roboray.sim.twin.board.lis3mdl_device import LIS3MDLDevice
import roboray.firmware.app as app
t = machine.twin
dev_depth = t.attach(0, MS5837Device())
dev_imu = t.attach(0, LSM6DSOXDevice())
dev_mag = t.attach(0, LIS3MDLDevice())
# live parts at rest: their own noise moves their counts (firmware/drivers/health.py)
dev_imu.set_noise(3)
dev_mag.set_noise(3)
dev_depth.set(101800.0, 15.0)
dev_imu.set_accel(0.0, 0.0, 9.80665)
dev_mag.set_field(0.19, 0.0, -0.49)
t.set_adc_volts(0, 8.0 / 3.0)
"""

BUILD = "v = app.build(machine, time, param_path=%r)\n"

#: One call of each task (the clock moved one 10 ms slot on first).
TASKS = (
    ("nav", "vclock.advance(10000); v.nav.step()"),
    ("link", "vclock.advance(10000); v.link.step()"),
    ("depth", "vclock.advance(10000); v.nav.depth_step()"),
    ("control", "vclock.advance(10000); v.flight.step()"),
    ("failsafes", "vclock.advance(10000); v.failsafes.update()"),
    ("telemetry", "v.reporter.fill()"),
)


def build(mp, param_path: str = "/tmp/bench_params.bin") -> None:
    """Wire the board in ``mp`` (a ``twin.interpreter()``) and build ``v``."""
    mp.exec(SETUP + BUILD % param_path)


def task_heap(mp, slots: int = 1200) -> dict[str, int]:
    """Heap bytes of one call of each task, after ``slots`` slots of the loop."""
    mp.exec("v.sched.run(%d)" % slots)
    return {name: mp.alloc_bytes(code) for name, code in TASKS}
