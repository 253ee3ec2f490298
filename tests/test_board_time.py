"""The board's compute time in the twin (``sim/twin/board/boardtime.py``):
code takes time as on the chip, so slots overrun and the watchdog bites as
they would on a Pico 2.

Here the charged model on CPython and on MicroPython's WebAssembly port
(the emulated RP2350 that counts instructions is ``test_rp2350_twin.py``).
"""

from __future__ import annotations

import pytest

from roboray.sim.twin.runner import Options, run
from roboray.shared.modes import NAMES

#: Eight tasks at a few hundred us each and a 1 ms collection (the
#: application's "gc" task, every 300 ms): a light loop.
LIGHT = {"tasks": {name: [300] * len(NAMES) for name in
                   ("nav", "link", "depth", "control", "leak", "battery", "params", "log")}, "gc_us": 0}
LIGHT["tasks"]["gc"] = [1000] * len(NAMES)


def model(**costs):
    m = {"tasks": {k: list(v) for k, v in LIGHT["tasks"].items()}, "gc_us": LIGHT["gc_us"]}
    for name, us in costs.items():
        m["tasks"][name] = [us] * len(NAMES)
    return m


def fly(board_model=None, interpreter="cpython", **kw):
    o = dict(scenario="passive-drop", interpreter=interpreter, depth=4.0, duration=14.0, board_model=board_model,
             board_time="model")
    o.update(kw)
    return run(Options(**o))


def test_a_light_loop_shows_its_slot_times_and_never_overruns():
    r = fly(model())
    # nav and link every slot, control in even slots (900 us), depth and
    # the log in odd ones (1.2 ms); leak, battery, params now and then; the
    # 1 ms collection one slot in 30, with nav only (1.3 ms)
    assert r["slot_p50_ms"] == pytest.approx(1.2, abs=0.05)
    assert 1.3 <= r["slot_p99_ms"] <= 1.6
    assert r["overruns"] == 0 and r["resets"] == 0
    assert r["gc_ms_max"] == pytest.approx(1.0)
    nav = r["board_time"]["tasks"]["nav"]
    assert nav["mean_us"] == 300 and nav["calls"] > 1000


def test_a_heavy_task_overruns_every_slot_and_the_watchdog_resets_the_board():
    # a 12 ms leak task every 50 ms: slots overrun, but never 25 in a row
    r = fly(model(leak=12000))
    assert r["overruns"] > 0 and r["resets"] == 0
    assert r["board_time"]["tasks"]["leak"]["max_us"] == 12000
    # a 12 ms nav task every 10 ms: every slot overruns, the scheduler stops
    # feeding the watchdog after 25 of them and the board resets
    # (a reset loop: the board comes back and overruns again)
    r = fly(model(nav=12000))
    assert r["overruns"] >= 25 and r["resets"] >= 2
    assert r["skipped_slots"] > 0 and r["slot_p99_ms"] >= 12.0
    assert r["console"].count("reset cause: WDT_RESET") == r["resets"]


def test_a_slower_clock_scales_the_compute_time():
    fast = fly(model(), cpu_mhz=150.0)
    slow = fly(model(), cpu_mhz=50.0)
    assert slow["board_time"]["tasks"]["nav"]["mean_us"] == 900
    assert slow["gc_ms_max"] == pytest.approx(3.0)
    assert slow["board_time"]["tasks"]["gc"]["calls"] > 30
    # every task's call costs three times as much (p99: the flash stalls of
    # the dive-state and log saves do not scale). The slots' make-up is the
    # firmware's choice: its radio and log budgets scale with the clock too
    # (firmware/app.py), so at 50 MHz, 9 ms for the radio, they wait for a
    # slot with room and run less often.
    for name, t in fast["board_time"]["tasks"].items():
        assert slow["board_time"]["tasks"][name]["p99_us"] == pytest.approx(3 * t["p99_us"]), name
    assert slow["board_time"]["tasks"]["link"]["calls"] < fast["board_time"]["tasks"]["link"]["calls"] / 2


def test_free_code_reports_no_loop_time():
    r = fly(board_time="free")
    assert r["board_time"]["source"] == "free" and r["slot_p99_ms"] is None and r["max_loop_ms"] == 0


@pytest.mark.micropython
def test_the_same_seed_gives_the_same_tlog_with_board_time_charged(tmp_path):
    paths = [tmp_path / ("run%d.tlog" % k) for k in range(2)]
    # the twin's default interpreter (RoboRay MicroPython on the host)
    reports = [run(Options(scenario="passive-drop", duration=12.0, tlog=str(p), board_model=model(nav=2500),
                           board_time="model")) for p in paths]
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert reports[0]["slot_p99_ms"] == reports[1]["slot_p99_ms"] > 2.5
