"""The application's start-up on the emulated Pico 2: bare, complete, faulty."""

from __future__ import annotations

import pytest

from roboray.sim import twin

pytestmark = pytest.mark.micropython

PARAMS = "/tmp/app/params.bin"


@pytest.fixture(scope="module")
def board():
    mp = twin.interpreter()
    yield mp
    mp.close()


@pytest.fixture
def mp(board):
    twin.reset(board)
    board.exec(
        "import os, machine, time\n"
        "from roboray.sim.twin.board import vclock, i2c_device\n"
        "from roboray.sim.twin.board.ms5837_device import MS5837Device\n"
        "from roboray.sim.twin.board.lsm6dsox_device import LSM6DSOXDevice\n"
        "from roboray.sim.twin.board.lis3mdl_device import LIS3MDLDevice\n"
        "import roboray.firmware.app as app\n"
        "t = machine.twin\n"
        "try:\n    os.mkdir('/tmp/app')\nexcept OSError:\n    pass\n"
        "for n in os.listdir('/tmp/app'):\n    os.remove('/tmp/app/' + n)\n"
        "def wire(depth=True, imu=True, mag=True):\n"
        "    global dev_depth, dev_imu, dev_mag\n"
        "    dev_depth = t.attach(0, MS5837Device()) if depth else None\n"
        "    dev_imu = t.attach(0, LSM6DSOXDevice()) if imu else None\n"
        "    dev_mag = t.attach(0, LIS3MDLDevice()) if mag else None\n"
        "    for d in (dev_imu, dev_mag):\n"
        "        if d is not None:\n"
        "            d.set_noise(3)   # live parts at rest\n"
        "    t.set_adc_volts(0, 7.6 / 3.0)\n"
        "def pulses():\n"
        "    return [t.pulse_ns(p) // 1000 for p in (10, 11, 12, 13)]\n"
    )
    return board


def start(mp, cycles=0):
    out = mp.exec("rc = app.main(cycles=%d, param_path=%r)" % (cycles, PARAMS))
    return mp.eval("rc"), out.splitlines()


def test_bare_board_gives_one_clear_line_per_missing_device_and_stops(mp):
    rc, lines = start(mp)
    assert rc == 1
    assert lines[0] == "RoboRay firmware unknown unknown"   # first, before any hardware
    assert lines[1] == "reset cause: PWRON_RESET"
    missing = [ln for ln in lines if ln.startswith("MISSING")]
    assert len(missing) == 3
    for part, address in (("MS5837-30BA", "0x76"), ("LSM6DSOX", "0x6A"), ("LIS3MDL", "0x1C")):
        line = next(ln for ln in missing if part in ln)
        assert "I2C0 (SDA GP4, SCL GP5)" in line and address in line and "check" in line
    assert any(ln.startswith("nothing at all answers on I2C0") for ln in lines)
    assert lines[-1].startswith("stopped:")
    assert not any("Traceback" in ln for ln in lines)
    assert mp.eval("pulses()") == [1000] * 4        # wings held flat (SERVO_SAFE_DEG 0)
    assert mp.eval("t.wdt_timeout_ms") == 0         # no watchdog to reset a stopped board


def test_one_missing_part_is_named_alone(mp):
    mp.exec("wire(mag=False)")
    rc, lines = start(mp)
    assert rc == 1
    missing = [ln for ln in lines if ln.startswith("MISSING")]
    assert len(missing) == 1 and "LIS3MDL at I2C address 0x1C: no answer" in missing[0]
    assert not any(ln.startswith("nothing at all") for ln in lines)


def test_a_depth_sensor_with_a_bad_prom_is_refused_with_its_reason(mp):
    mp.exec("wire()\ndev_depth.corrupt_prom()")
    rc, lines = start(mp)
    assert rc == 1
    assert any("MS5837" in ln and "PROM CRC mismatch" in ln for ln in lines)


def test_complete_board_runs_the_loop_with_the_driver_tasks(mp):
    mp.exec("wire()\ndev_depth.set(130000.0, 16.0)\ndev_imu.set_accel(0.1, 0.2, 9.7)")
    rc, lines = start(mp, cycles=300)
    assert rc == 0
    assert lines[:2] == ["RoboRay firmware unknown unknown", "reset cause: PWRON_RESET"]
    assert "running: 9 tasks, loop 100 Hz" in lines
    assert not any(ln.startswith(("MISSING", "WARNING")) for ln in lines)
    assert mp.eval("t.wdt_feeds") == 300 and mp.eval("t.wdt_expired()") is False
    assert mp.eval("pulses()") == [1000] * 4


def test_build_gives_the_vehicle_to_extend_with_one_line_a_task(mp):
    mp.exec("wire()\ndev_depth.set(150000.0, 10.0)\nv = app.build(machine, time, param_path=%r)\n"
            "steps = []\nv.sched.add('estimator', lambda: steps.append(v.depth.pressure_pa), app.MAIN_MS)\n"
            "v.sched.run(50)" % PARAMS)
    # every slot: the collection's too, which runs with the every-slot tasks only
    assert mp.eval("len(steps)") == 50
    assert abs(mp.eval("steps[-1]") - 150000) <= 10
    assert mp.eval("[v.imu.health.healthy(), v.mag.health.healthy(), v.depth.health.healthy(), "
                   "v.battery.health.healthy()]") == [True, True, True, True]
    assert mp.eval("v.battery.volts[0]") == pytest.approx(7.6, abs=0.01)
    assert mp.eval("v.sched.overruns") == 0


def test_saved_parameters_calibrate_the_servos_at_boot(mp):
    mp.exec("from roboray.shared.params import ParamTable\nfrom roboray.firmware.param_store import ParamStore\n"
            "p = ParamTable(app.PARAMS)\np.set_by_name('SERVO2_MIN', 1200)\np.set_by_name('SERVO_SAFE_DEG', 45.0)\n"
            "ParamStore(p, %r).save()\nwire()" % PARAMS)
    rc, lines = start(mp, cycles=1)
    assert "params: %d loaded from %s" % (mp.eval("len([d for d in app.PARAMS if len(d) < 6 or not d[5] & 1])"),
                                          PARAMS) in lines
    assert mp.eval("pulses()") == [1500, 1600, 1500, 1500]


def test_ctrl_c_stops_the_watchdog_and_leaves_the_wings_safe(mp):
    mp.exec("wire()\nv = app.build(machine, time, param_path=%r)\n"
            "def interrupt():\n    if v.sched.cycles == 20:\n        raise KeyboardInterrupt\n"
            "v.sched.add('user', interrupt, app.MAIN_MS)\nv.wings.command[0] = 1.0\n" % PARAMS)
    out = mp.exec("try:\n    v.run()\nexcept KeyboardInterrupt:\n    pass\n")
    assert "stopped at the REPL: watchdog off, wings safe" in out
    assert mp.eval("t.wdt_timeout_ms") == 0
    mp.exec("time.sleep_ms(5000)")
    assert mp.eval("t.wdt_expired()") is False
    assert mp.eval("pulses()") == [1000] * 4


def test_a_dead_loop_lets_the_watchdog_reset_the_board(mp):
    mp.exec("wire()\nv = app.build(machine, time, param_path=%r)\n"
            "def hang():\n    if v.sched.cycles == 10:\n        time.sleep_ms(2000)\n"
            "v.sched.add('hang', hang, app.MAIN_MS)\n"
            "vclock.set_hook(lambda dt: t.check_watchdog())\n"
            "try:\n    v.run()\nexcept machine.BoardReset as e:\n    cause = e.cause\n"
            "vclock.set_hook(None)" % PARAMS)
    assert mp.eval("cause") == mp.eval("machine.WDT_RESET")
    rc, lines = start(mp)
    assert lines[1] == "reset cause: WDT_RESET"


_CPYTHON_RUN = """
import sys
from roboray.sim.twin.board import vclock
sys.modules['time'] = vclock
from roboray.sim.twin.board import machine
sys.modules['machine'] = machine
from roboray.sim.twin.board.ms5837_device import MS5837Device
from roboray.sim.twin.board.lsm6dsox_device import LSM6DSOXDevice
from roboray.sim.twin.board.lis3mdl_device import LIS3MDLDevice
t = machine.twin
t.attach(0, MS5837Device()).set(130000.0, 16.0)
t.attach(0, LSM6DSOXDevice()).set_noise(3)
t.attach(0, LIS3MDLDevice()).set_noise(3)
t.set_adc_volts(0, 7.6 / 3.0)
import roboray.firmware.app as app
v = app.build(machine, vclock, param_path=sys.argv[1])
v.sched.run(100)
print('reading', v.depth.pressure_pa, v.depth.temp_cc, v.imu.raw[6], v.sched.overruns)
print('rc', app.main(cycles=10, param_path=sys.argv[1]))
"""


def test_the_same_firmware_runs_on_cpython_with_the_twins_modules(mp, tmp_path):
    # The twin's --interpreter cpython: the same files, time and machine
    # swapped in sys.modules of a fresh process, as on MicroPython.
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", _CPYTHON_RUN, str(tmp_path / "params.bin")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    reading = next(line.split() for line in lines if line.startswith("reading "))
    # 1 g at 0.122 mg/LSB: 8197 counts, and the live part's own noise (+-3)
    assert reading[1:3] == ["130000", "1600"] and abs(int(reading[3]) - 8197) <= 3 and reading[4] == "0"
    assert "RoboRay firmware unknown unknown" in lines and lines[-1] == "rc 0"
    mp.exec("wire()\ndev_depth.set(130000.0, 16.0)\nv = app.build(machine, time, param_path=%r)\n"
            "v.sched.run(100)" % PARAMS)
    assert "reading %d %d %d %d" % tuple(mp.eval("[v.depth.pressure_pa, v.depth.temp_cc, v.imu.raw[6], "
                                                 "v.sched.overruns]")) in lines
