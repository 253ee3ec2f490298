"""Radio input that is no finite, reachable number, as a class, in flight on
the twin (issue 26 item 2): every message the endpoint acts on (its own
table, ``sim/radio_values.py``), NaN, +-inf, +-1e30 in each float field and
the int32 limits in each int32 field, sent by pymavlink on the twin's radio
(a pseudo-terminal at 57,600 baud) while the vehicle flies to its target in
TARGET. Each answer is the protocol's refusal (or, for a field the handler
does not read, the valid message's answer), and the dive is the dive
without them: the target kept, the position estimate finite, no FAILSAFE,
the link answering to the end, the landing on the target.

One dive on the default interpreter; 834 messages (729 answered)."""

from __future__ import annotations

import math
import threading
import time

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as pm

from roboray.sim import radio_values as R
from roboray.sim.twin.runner import Options, Twin


def _until(c, accept, timeout, seen=None):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        m = c.recv_match(blocking=True, timeout=min(0.5, max(0.01, end - time.monotonic())))
        if m is None:
            continue
        if seen is not None:
            seen(m)
        if accept(m):
            return m
    return None


def _operate(device: str, got: dict, done: threading.Event) -> None:
    c = mavutil.mavlink_connection(device, baud=57600, source_system=255, source_component=191, dialect="common")
    c.mav.robust_parsing = True
    positions: list = []
    targets: list = []

    def seen(m):
        t = m.get_type()
        if t == "LOCAL_POSITION_NED":
            positions.append((m.x, m.y, m.z))
        elif t == "POSITION_TARGET_LOCAL_NED":
            targets.append((m.x, m.y, m.z))
        elif t == "HEARTBEAT":
            got.setdefault("modes", set()).add(m.custom_mode)

    try:
        assert c.wait_heartbeat(timeout=60) is not None, "no heartbeat"
        cur = _until(c, lambda m: m.get_type() == "MISSION_CURRENT" and m.mission_mode == 1 and m.mission_state == 3,
                     90, seen)
        assert cur is not None, "never in TARGET"
        c.mav.command_long_send(1, 1, pm.MAV_CMD_REQUEST_MESSAGE, 0, pm.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED,
                                0, 0, 0, 0, 0, 0)
        tgt = _until(c, lambda m: m.get_type() == "POSITION_TARGET_LOCAL_NED", 5, seen)
        pos = _until(c, lambda m: m.get_type() == "LOCAL_POSITION_NED", 5, seen)
        base = {"target": (tgt.x, tgt.y, tgt.z), "position": (pos.x, pos.y)}
        got["target"] = base["target"]
        c.mav.param_request_read_send(1, 1, b"FS_GCS_TIMEOUT", -1)
        fs = _until(c, lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == "FS_GCS_TIMEOUT", 5, seen)
        got["t_start"] = time.monotonic()
        del targets[:]      # (from here on: the target the cases must leave alone)
        results: list = []
        base_result: dict = {}
        got["results"] = results
        got["base_result"] = base_result
        todo = R.cases(base)
        i = 0
        while i < len(todo):
            case = todo[i]
            if case.answer == "MISSION_ACK":
                c.mav.mission_count_send(1, 1, 2, 0)
                for seq in (0, 1):
                    r = _until(c, lambda m: m.get_type() == "MISSION_REQUEST_INT" and m.seq == seq, 3, seen)
                    assert r is not None, "%s: no request for item %d" % (case.name, seq)
                    if seq == 0:
                        c.mav.mission_item_int_send(1, 1, 0, pm.MAV_FRAME_LOCAL_NED, pm.MAV_CMD_NAV_WAYPOINT,
                                                    0, 1, 0, 0, 0, 0, 0, 0, 0, 0)
                c.mav.send(case.msg)
                a = _until(c, lambda m: m.get_type() == "MISSION_ACK", 3, seen)
                results.append((case, None if a is None else a.type))
                i += 1
            elif case.answer == "COMMAND_ACK":
                # the cases of one command in a burst of up to 5 (the bad values of a
                # field), their acknowledgements in order: the radio's pace allows it
                burst = [case]
                while (len(burst) < 5 and i + len(burst) < len(todo)
                       and todo[i + len(burst)].answer == "COMMAND_ACK" and todo[i + len(burst)].command == case.command
                       and burst[0].expect != "base" and todo[i + len(burst)].expect != "base"):
                    burst.append(todo[i + len(burst)])
                for b in burst:
                    c.mav.send(b.msg)
                for b in burst:
                    a = _until(c, lambda m: m.get_type() == "COMMAND_ACK" and m.command == case.command, 3, seen)
                    r = None if a is None else a.result
                    if b.expect == "base":
                        base_result[(b.name.split()[0], b.command)] = r
                    results.append((b, r))
                i += len(burst)
            elif case.answer == "PARAM_VALUE":
                c.mav.send(case.msg)
                a = _until(c, lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == "FS_GCS_TIMEOUT", 3, seen)
                results.append((case, None if a is None else a.param_value))
                i += 1
            else:
                c.mav.send(case.msg)
                time.sleep(0.02)
                i += 1
        got["t_end"] = time.monotonic()
        got["fs_timeout"] = fs.param_value
        # the link still answers, and the target is the one it was
        c.mav.command_long_send(1, 1, pm.MAV_CMD_REQUEST_MESSAGE, 0, pm.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED,
                                0, 0, 0, 0, 0, 0)
        after = _until(c, lambda m: m.get_type() == "POSITION_TARGET_LOCAL_NED", 5, seen)
        got["target_after"] = None if after is None else (after.x, after.y, after.z)
        got["in_flight_after"] = _until(c, lambda m: m.get_type() == "MISSION_CURRENT", 5, seen).mission_state
        reached = _until(c, lambda m: m.get_type() == "MISSION_ITEM_REACHED", 150, seen)
        got["reached"] = None if reached is None else reached.seq
    except Exception as exc:  # reported by the test's assertions
        got["error"] = repr(exc)
    finally:
        got["positions"] = positions
        got["targets"] = targets
        c.close()
        done.set()


def test_every_handled_message_with_no_number_in_each_field_in_flight():
    got: dict = {}
    done = threading.Event()

    def on_radio(radio):
        threading.Thread(target=_operate, args=(radio.device, got, done), daemon=True).start()

    # a 30 m bottom: a dive long enough for every case at the radio's pace (FS_DEPTH_MAX,
    # 20 m by default, beyond it: its warning is not what is tested). Three times real
    # time: the cases are paced by the radio in simulated time, the operator's own work
    # adds a little more at a higher pace (measured, loaded: the cases from 10.2 s to
    # 61.5 s simulated at 2x, to 70.6 s at 4x; the landing at 77.8 s)
    twin = Twin(Options(scenario="target-landing", radio="pty", speedup=3.0, depth=30.0, duration=300.0,
                        params={"FS_DEPTH_MAX": 40.0}),
                on_radio=on_radio)
    report = twin.run()
    assert done.wait(60)
    assert "error" not in got, (got.get("error"), "after %d answered cases in %.1f s; dive %s" % (
        len(got.get("results", [])), time.monotonic() - got.get("t_start", time.monotonic()), report.get("modes")))
    wrong = []
    for case, r in got["results"]:
        e = case.expect
        if e == "base":
            ok = r is not None
        elif e == "as-base":
            ok = r == got["base_result"][(case.name.split()[0], case.command)]
        elif e == "refused":
            ok = r is not None and r != pm.MAV_RESULT_ACCEPTED
        elif e == "unchanged":
            ok = r == got["fs_timeout"]
        else:
            ok = r in e
        if not ok:
            wrong.append((case.name, r, e))
    assert not wrong, wrong[:20]
    assert len(got["results"]) == sum(1 for c in R.cases({"target": (0, 0, 0), "position": (0, 0)}) if c.answer)
    # all of it in flight: still flying to the target after the last (MISSION_STATE ACTIVE)
    assert got["in_flight_after"] == 3
    # (the valid COMMAND_INT DO_REPOSITION sets it again from metres x 1e4: 2.0 as 1.99999988 in float32)
    assert got["target_after"] == pytest.approx(got["target"], abs=1e-5)
    # the target's place never moves; its bottom is the base's, or 0 (CTL_DEPTH_M's) after the
    # mission item with a NaN z: "no depth given", a valid item, accepted (and the next restores it)
    n, e, d = got["target"]
    odd = [t for t in got["targets"] if t != pytest.approx((n, e, d), abs=1e-5) and t != pytest.approx((n, e, 0.0), abs=1e-5)]
    assert got["targets"] and not odd, odd[:5]
    assert got["positions"] and all(math.isfinite(v) for p in got["positions"] for v in p)
    assert "FAILSAFE" not in [m for _, m in report["modes"]] and report["failsafes"] == []
    assert got["reached"] == 1 and report["landed"]
    north, east = report["landing_point"]
    assert math.hypot(north - got["target"][0], east - got["target"][1]) < 0.25, report["landing_point"]
