"""The application's flight layer on MicroPython, on a wired emulated board.

No world here (``sim/twin/bench.py``: a vehicle at rest under the surface):
the loop's tasks, the arming and mode checks, the ground's velocity set
points and reboot, a bad mounting parameter at boot, and the heap each task
allocates (held to the figures ``roboray-sim bench sil`` prints).
"""

from __future__ import annotations

import math
import os

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from roboray.firmware import app  # noqa: E402
from roboray.firmware.param_store import encode  # noqa: E402
from roboray.shared.params import ParamTable  # noqa: E402
from roboray.sim import twin  # noqa: E402
from roboray.sim.twin import bench  # noqa: E402

PARAMS = "/tmp/bench_params.bin"

#: Heap bytes one call may allocate (roboray-sim bench sil --json, "firmware_heap_bytes").
# bytes a task allocates on stock MicroPython (floats boxed, 16 B each);
# telemetry copies its quaternion, rates and variances element by element,
# which boxes each on stock and costs nothing on RoboRay's build (a slice
# assignment builds a slice object on both: tests/test_flight_allocation.py);
# 512 since the depth and vertical speed variances joined them (Telemetry.var_dz,
# for LOCAL_POSITION_NED_COV: two floats more)
HEAP = {"nav": 4096, "link": 2048, "depth": 0, "control": 512, "failsafes": 256, "telemetry": 512}


@pytest.fixture(scope="module")
def board():
    mp = twin.interpreter()
    yield mp
    mp.close()


@pytest.fixture
def mp(board):
    twin.reset(board)
    board.exec("import os\ntry:\n    os.remove(%r)\nexcept OSError:\n    pass\n" % PARAMS)
    return board


def test_the_loop_runs_eight_tasks_and_the_estimator_settles_at_rest(mp):
    bench.build(mp, PARAMS)
    assert mp.eval("v.sched.names") == ["nav", "control", "depth", "leak", "battery", "params", "link", "log", "gc"]
    mp.exec("v.sched.run(1200)")
    assert mp.eval("v.nav.valid(0x30)") is True            # attitude and depth valid
    # 101800 Pa: the port 48.4 mm deep, the centre of buoyancy 23.1 mm above it
    assert mp.eval("v.nav.est.nav[0]") == pytest.approx(0.0253, abs=0.003)
    assert mp.eval("v.failsafes.active") == 0
    assert mp.eval("v.sched.overruns") == 0 and mp.eval("sum(v.sched.task_errors)") == 0


def test_the_budgets_of_the_radio_and_the_log_follow_the_cpu_clock(mp):
    # measured at the Pico 2's 150 MHz; at 125 MHz the same work takes 1.2x
    # as long, and the log let in on its 150 MHz budget overran a slot
    def budgets():
        twin.reset(mp)
        bench.build(mp, PARAMS)
        return mp.eval("[v.sched._budget[v.sched.names.index(n)] for n in ('link', 'log')]")

    assert budgets() == [app.LINK_BUDGET_US, app.LOG_COST_US]
    mp.exec("import machine\nmachine.set_boot_freq(125000000)")
    try:
        assert mp.eval("machine.freq()") == 125000000
        assert budgets() == [app.LINK_BUDGET_US * 6 // 5, app.LOG_COST_US * 6 // 5]
    finally:
        mp.exec("machine.set_boot_freq(150000000)")


def test_arming_waits_for_the_estimator_and_lands_in_passive(mp):
    bench.build(mp, PARAMS)
    mp.exec("v.sched.run(100)")
    assert mp.eval("v.modes.arm()") == [False, "no attitude estimate"]
    mp.exec("v.sched.run(1100)")
    assert mp.eval("v.modes.arm()") == [True, "ok"]
    mp.exec("v.sched.run(50)")
    assert mp.eval("v.modes.mode") == 1                     # PASSIVE
    # PASSIVE_WING_DEG 45 on every wing: 1500 us between SERVOn_MIN 1000 and MAX 2000
    assert mp.eval("[t.pulse_ns(p) // 1000 for p in (10, 11, 12, 13)]") == [1500] * 4
    assert mp.eval("v.params.get(v.params.index('BARO1_GND_PRESS'))") == pytest.approx(101800.0, abs=30.0)


@pytest.mark.skipif(app.control_mod is None, reason="the controller (shared/control) is not in this firmware yet")
def test_controlled_modes_need_the_estimates_and_the_target_they_use(mp):
    bench.build(mp, PARAMS)
    mp.exec("v.sched.run(1200)\nv.modes.arm()\nv.sched.run(10)")
    assert mp.eval("v.modes.request(4)") == [False, "no position estimate"]
    # fixes from the tracker relay (at rest at the release point)
    mp.exec("for _ in range(5):\n    v.nav.fix(0.0, 0.0)\n    v.sched.run(100)\n")
    assert mp.eval("v.modes.request(4)") == [False, "no target set"]
    mp.exec("v.telemetry.has_target = True")
    assert mp.eval("v.modes.request(4)") == [True, "ok"]
    assert mp.eval("v.modes.request(3)") == [True, "ok"]    # VELOCITY


def test_without_a_controller_the_controlled_modes_are_refused_with_a_reason(mp):
    bench.build(mp, PARAMS)
    mp.exec("v.sched.run(1200)\nv.modes.arm()\nv.failsafes.has_controller = False\n"
            "sent = []\nv.failsafes.link = type('L', (), {'send_text': lambda s, sev, text: sent.append(text),"
            " 'gcs_last_ms': -1, 'now_ms': 0})()")
    assert mp.eval("v.modes.request(2)") == [False, "pre-arm check failed"]
    assert mp.eval("sent") == ["no controller in this firmware"]


def test_a_velocity_set_point_from_the_ground_reaches_the_endpoint(mp):
    bench.build(mp, PARAMS)
    ground = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    frame = mavlink.MAVLink_set_position_target_local_ned_message(
        0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, 0x0DC7, 0, 0, 0, 0.1, -0.05, 0.3, 0, 0, 0, 0, 0).pack(ground)
    mp.exec("t.uart(0).feed(%r)\nv.sched.run(20)" % frame)
    assert mp.eval("v.link.ep.velocity_count") == 1
    assert mp.eval("list(v.link.ep.velocity_ned)") == pytest.approx([0.1, -0.05, 0.3], abs=1e-6)
    assert mp.eval("v.link.ep.target_count") == 0           # velocity bits only: not a position target


def test_a_reboot_from_the_ground_saves_and_resets_the_board(mp):
    bench.build(mp, PARAMS)
    mp.exec("v.sched.run(10)\nsaves = v.store.saves\nv.params.set_by_name('SR_STATUS', 2.0)\n"
            "v.link.ep.reboot_requested = True\n"
            "try:\n    v.link.step()\nexcept machine.BoardReset as e:\n    cause = e.cause\n")
    assert mp.eval("cause") == mp.eval("machine.WDT_RESET")
    # the change was saved before the reset (whatever the first slots saved)
    assert mp.eval("v.store.saves - saves") == 1


def test_an_unsupported_mounting_stops_the_start_with_its_reason(mp):
    table = ParamTable(app.PARAMS)
    table.set_by_name("AHRS_ORIENTATION", 3)                 # yaw 135: not a quarter turn
    mp.write_file(PARAMS, encode(table))
    mp.exec(bench.SETUP)
    out = mp.exec("rc = app.main(cycles=10, param_path=%r)" % PARAMS)
    assert mp.eval("rc") == 1
    assert "navigation: AHRS_ORIENTATION 3 is not supported" in out
    assert out.splitlines()[-1].startswith("stopped:")


@pytest.mark.parametrize("orientation", [0, 2, 4, 6, 8, 10, 12, 14])
def test_each_mounting_maps_the_chip_axes_to_the_body_axes(mp, orientation):
    # AHRS_ORIENTATION (ArduPilot's numbering): a yaw of 0, 90, 180, 270 deg
    # (yaw 90 turns chip x onto body y), then a roll of 180 deg from 8 on
    yaw = (orientation % 8) // 2 * 90
    c, s = round(math.cos(math.radians(yaw))), round(math.sin(math.radians(yaw)))
    roll = -1 if orientation >= 8 else 1

    def body(v):
        x, y, z = v
        return [c * x - s * y, roll * (s * x + c * y), roll * z]

    table = ParamTable(app.PARAMS)
    table.set_by_name("AHRS_ORIENTATION", orientation)
    mp.write_file(PARAMS, encode(table))
    mp.exec(bench.SETUP + "dev_imu.set_accel(1.0, -2.0, 9.5)\ndev_imu.set_gyro(0.1, -0.2, 0.3)\n"
            "dev_mag.set_field(0.19, -0.05, -0.49)\n" + bench.BUILD % PARAMS
            # the first step empties what the FIFO batched during set-up
            + "vclock.advance(10000)\nv.nav.step()\nvclock.advance(10000)\nv.nav.step()")
    got = mp.eval("list(v.nav.body)")
    chip = mp.eval("list(v.imu.accel) + list(v.imu.gyro) + list(v.mag.mag_gauss)")
    want = body(chip[0:3]) + body(chip[3:6]) + body(chip[6:9])
    assert got == pytest.approx(want, rel=1e-6, abs=1e-9)
    assert mp.eval("v.nav.imu_samples") == 1


def test_each_task_allocates_within_its_figure(mp):
    bench.build(mp, PARAMS)
    heap = bench.task_heap(mp)
    for name, limit in HEAP.items():
        assert heap[name] <= limit, (name, heap[name])
