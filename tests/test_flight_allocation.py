"""What the flight tasks allocate on RoboRay's MicroPython (issue 29 item
1): the firmware built on its wired board (as ``roboray-sim bench board``
builds it) on the host build of RoboRay MicroPython (floats in the object
word, as on the Pico 2), each call measured between two ``gc.mem_alloc()``
readings with the collector off, after a warm-up call. The emulated
sensors' own garbage is the twin's, not the firmware's: the driver reads
are measured apart from the estimator they feed."""

from __future__ import annotations

import os
import subprocess
import tempfile
from pathlib import Path

import pytest

from roboray.sim import twin
from roboray.sim.twin import bench
from roboray.tools.micropython import roboray_host

pytestmark = pytest.mark.skipif(not roboray_host.available(),
                                reason="RoboRay MicroPython's host build runs on Linux on x86")

#: Calls that allocate nothing on RoboRay's build (stock boxes their floats).
ZERO = (
    "v.reporter.fast()",
    "v.reporter.position()",
    "v.reporter.sensors()",
    "v.reporter.servo()",
    "v.reporter.power()",
    "v.nav.est.imu(vclock.ticks_us(), 0.01, -0.02, 0.003, 0.1, -0.2, 9.8)",
    "v.nav.est.mag(vclock.ticks_us(), 0.19, 0.01, -0.49)",
    "v.nav.est.check(vclock.ticks_us())",
    "v.flight.step()",
    "v.failsafes.update()",
)


def test_the_flight_calls_allocate_nothing_on_roboray_micropython():
    d = Path(tempfile.mkdtemp())
    from roboray.sim.twin.runner import install_board_lib
    lib = install_board_lib(d / "lib")
    code = (twin.PRELUDE + bench.SETUP + bench.BUILD % str(d / "params.bin") + "v.sched.run(300)\n"
            "def _alloc(f):\n"
            "    f()\n"
            "    gc.collect()\n"
            "    gc.disable()\n"
            "    a = gc.mem_alloc()\n"
            "    vclock.advance(10000)\n"
            "    f()\n"
            "    b = gc.mem_alloc()\n"
            "    gc.enable()\n"
            "    return b - a\n")
    for call in ZERO:
        code += "print('ALLOC', _alloc(lambda: %s))\n" % call
    proc = subprocess.run(roboray_host.command("-X", "heapsize=600000", "-c", code),
                          env=dict(os.environ, MICROPYPATH=str(lib)), capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    got = [int(line.split()[1]) for line in proc.stdout.splitlines() if line.startswith("ALLOC ")]
    assert dict(zip(ZERO, got)) == dict.fromkeys(ZERO, 0)
