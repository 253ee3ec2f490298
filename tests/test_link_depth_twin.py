"""A dive that does not need the link (issue 27): the link-lost failsafe
below ``FS_GCS_DEPTH``, what comes back with the link, the pre-arm check
of TARGET's target, and a TARGET dive with no link after the release.

The firmware runs unchanged on the emulated board in the twin
(``--interpreter cpython``, as ``test_failsafe_twin.py``: the logic is the
point); the link is cut by the twin's ``radio-loss`` fault, nothing
crosses either way. What the operator sees is read where they see it: the
ground's STATUSTEXTs, and the tlog decoded by pymavlink.
"""

from __future__ import annotations

import math

from pymavlink import mavutil

from roboray.shared.estimator import health as eh
from roboray.sim.twin import faults
from roboray.sim.twin.ground import EPOCH_US, Action
from roboray.sim.twin.runner import Options, run


def fly(*fault_specs, scenario="passive-drop", params=None, duration=22.0, depth=4.0, operator=(), tlog=None,
        target=None, water="fresh"):
    return run(Options(scenario=scenario, interpreter="cpython", depth=depth, duration=duration, target=target,
                       water=water,
                       faults=[faults.parse(f) for f in fault_specs], params=dict(params or {}),
                       operator=list(operator), tlog=str(tlog) if tlog else None))


def texts(report, since=0.0):
    return [t[2] for t in report["statustext"] if t[0] >= since]


def tlog_messages(path, kinds):
    """(virtual time s, message) of the tlog's frames of ``kinds``, from the vehicle."""
    m = mavutil.mavlink_connection(str(path), dialect="common")
    out = []
    while True:
        msg = m.recv_match(type=list(kinds))
        if msg is None:
            return out
        if msg.get_srcSystem() == 1:
            out.append((msg._timestamp - EPOCH_US * 1e-6, msg))


def test_a_link_lost_deeper_than_fs_gcs_depth_is_expected_and_everything_resumes_with_it(tmp_path):
    # released ~9.6 s, below 0.5 m by ~11 s; the link goes at 12 s (missed
    # from 17 s: FS_GCS_TIMEOUT) and is back at 20 s, the vehicle still
    # sinking in 6 m of water (on the bottom at ~24 s, the run ends 2 s
    # later); FS_GCS_ENABLE 3 would hold FAILSAFE mode
    log = tmp_path / "deep.tlog"
    r = fly("radio-loss@12", "radio-ok@20", params={"FS_GCS_ENABLE": 3, "FS_GCS_DEPTH": 0.5}, duration=40.0,
            depth=6.0, operator=[Action(21.5, "param", ("FS_GCS_TIMEOUT", 6.0), max_tries=1)], tlog=log)
    assert r["failsafes"] == [] and r["failsafe_flags_reported"] & 1 == 0
    assert [m for _, m in r["modes"]] == ["PASSIVE"]
    said = [t for t in r["statustext"] if t[2] == "link lost below 0.5 m, expected"]
    # said once, while going below 0.5 m, before the link went: the operator saw it
    assert len(said) == 1 and said[0][0] < 12.0
    regained = [t for t in r["statustext"] if t[2] == "link regained"]
    assert len(regained) == 1 and 20.0 <= regained[0][0] <= 21.5
    # commands: the parameter set after the link came back was answered
    assert r["operator"][-1]["result"] == "6" and r["operator"][-1]["t"] >= 21.5
    # telemetry: nothing from the vehicle while the link was gone, then the
    # streams again; fixes: the estimator takes them again (SYS_STATUS's
    # vision bit, the estimator's FIX_OK), and the dead-reckoned position's
    # variance grew while they were missing, then shrank
    frames = tlog_messages(log, ("LOCAL_POSITION_NED", "SYS_STATUS", "LOCAL_POSITION_NED_COV"))
    assert not [t for t, _ in frames if 12.2 < t < 20.0]
    after = [(t, m) for t, m in frames if t >= 20.0]
    assert {m.get_type() for _, m in after} == {"LOCAL_POSITION_NED", "SYS_STATUS", "LOCAL_POSITION_NED_COV"}
    vision = [t for t, m in after if m.get_type() == "SYS_STATUS" and m.onboard_control_sensors_health & 0x80]
    assert vision and vision[0] < 23.0
    cov = [(t, m.covariance[0]) for t, m in frames if m.get_type() == "LOCAL_POSITION_NED_COV"]
    before = [v for t, v in cov if 10.0 <= t < 12.0]
    first_back = [v for t, v in cov if 20.0 <= t < 21.0]
    last = [v for t, v in cov if t >= 24.0]
    assert before and first_back and last
    assert first_back[0] > 3.0 * max(before)      # eight seconds reckoned without a fix
    assert last[-1] < 0.5 * first_back[0]          # fixes again


def test_a_link_lost_shallower_than_fs_gcs_depth_is_the_failsafe():
    # the same loss with FS_GCS_DEPTH beyond the bottom: the failsafe acts
    r = fly("radio-loss@12", "radio-ok@18", params={"FS_GCS_ENABLE": 3, "FS_GCS_DEPTH": 300.0})
    assert [f["name"] for f in r["failsafes"]] == ["link lost"]
    assert [m for t, m in r["modes"] if t >= 15.0] == ["FAILSAFE"]
    assert "link lost below 300 m, expected" not in texts(r) and "link regained" not in texts(r)
    assert "Failsafe cleared: link lost" in texts(r)


def test_arming_in_target_without_a_target_is_refused_before_the_dive():
    # the operator selects TARGET on deck and never sends a target: the
    # scenario's arming (from 9 s, asked again while refused) is refused
    # with the reason and ArduPilot's PreArm text, and the vehicle is not let go
    r = fly(operator=[Action(3.0, "mode", ("TARGET",), max_tries=1)], duration=14.0)
    assert r["operator"][-1]["result"] == "accepted"
    assert "PreArm: TARGET mode has no target" in texts(r) and "no target set" in texts(r)
    arm = next(a for a in r["operator"] if a["action"] == "arm")
    assert arm["result"].startswith("refused")
    assert [a for _, a in r["arming"]] == ["disarmed"] and r["released_at_s"] is None


def test_a_target_dive_without_the_link_after_release_lands_on_dead_reckoning():
    # target-landing in the sea (2 m north from 10 m): target and mode set
    # before the release at ~9.8 s, the link gone for good at 11 s, so no
    # fix after it. No failsafe acts: in salt water (the twin sets
    # BARO_SPEC_GRAV 1.025 for it) the default FS_GCS_DEPTH counts as 0.1 m,
    # and the dead-reckoned position stays valid. The vehicle lands on the
    # target within the dead-reckoning goal, 0.5 m (0.027 m here, the
    # nominal vehicle; the Monte Carlo's p95 is in docs/benchmarks.md)
    r = fly("radio-loss@11", scenario="target-landing", depth=10.0, duration=60.0, water="sea",
            params={"FS_GCS_ENABLE": 3})
    assert r["released_at_s"] is not None and r["released_at_s"] < 10.5
    assert r["landed"] and r["failsafes"] == []
    assert texts(r)[-1] == "link lost below 0.1 m, expected"
    assert [m for t, m in r["modes"] if t >= 10.5] == []      # TARGET throughout
    assert r["landing_error_m"] < 0.5
