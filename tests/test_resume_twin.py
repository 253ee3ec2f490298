"""A dive survives a reset (issue 16), in the twin.

target-landing: released at about 9.7 s from just under the surface, on the
bottom (10 m) at about 34 s. A watchdog reset (the loop hangs, the watchdog
resets the board a second later) or a power cut (at a flash step of the
parameter save the operator's change starts) anywhere in the descent: the
board comes back, finds the dive's state (the watchdog's scratch words, or
flash), sees from the pressure that it is under water, resumes TARGET once
its estimator has realigned, and still lands within 0.5 m; the ground reads
why in a STATUSTEXT. Most runs are on CPython (``firmware/resume.py``'s
logic is the point); one runs on the default MicroPython interpreter.
"""

from __future__ import annotations

import pytest

from roboray.sim.twin import faults
from roboray.sim.twin.runner import Options, run


def fly(*specs, scenario="target-landing", interpreter="cpython", **kw):
    return run(Options(scenario=scenario, interpreter=interpreter, faults=[faults.parse(s) for s in specs], **kw))


def texts(report):
    return [t[2] for t in report["statustext"]]


def resumed(report, cause):
    return [t for t in report["statustext"] if t[2].startswith(cause) and "resumed TARGET" in t[2]]


@pytest.mark.parametrize("at", [11, 15, 20, 25, 31])
def test_a_watchdog_reset_in_the_descent_resumes_the_dive(at):
    r = fly("watchdog@%d" % at)
    assert r["resets"] == 1 and r["power_cuts"] == 0
    assert r["landing_error_m"] < 0.5, r["landing_error_m"]
    said = resumed(r, "Watchdog reset at")
    assert said and said[0][1] == 2                        # MAV_SEVERITY_CRITICAL, seen by the ground
    assert "dive state from scratch: TARGET, waiting for the depth to resume" in r["console"]
    # disarmed in PASSIVE by the reset, then armed in the dive's mode again, without an arming
    modes = [m for t, m in r["modes"] if t > at and m != "OFF"]
    assert modes == ["PASSIVE", "TARGET"], r["modes"]
    assert [a for t, a in r["arming"] if t > at] == ["disarmed", "armed"], r["arming"]
    assert "estimator" not in [f["name"] for f in r["failsafes"]]


@pytest.mark.parametrize("spec", ["powercut@13", "powercut@20", "powercut@28"])
def test_a_power_cut_in_the_descent_resumes_the_dive(spec):
    r = fly(spec)
    assert r["power_cuts"] == 1 and r["resets"] == 0
    assert r["landing_error_m"] < 0.5, r["landing_error_m"]
    said = resumed(r, "Power lost at")
    assert said and said[0][1] == 2
    assert "dive state from flash: TARGET, waiting for the depth to resume" in r["console"]
    assert r["modes"][-1][1] == "TARGET" and r["failsafes"] == []


def test_a_board_powered_off_armed_at_the_surface_comes_back_disarmed():
    # a passive drop onto a bottom 0.4 m down, resting there armed: never
    # deeper than RESUME_DEPTH_M, as on deck or on the bench
    r = fly("powercut@14", scenario="bottom-rest", depth=0.4, duration=28.0)
    assert r["power_cuts"] == 1
    assert [a for t, a in r["arming"] if t > 14.0] == ["disarmed"], r["arming"]
    assert r["modes"][-1][1] == "PASSIVE"
    said = [t for t in r["statustext"] if t[2].startswith("Power lost at")]
    assert len(said) == 1 and said[0][2].endswith("(surface): disarmed") and said[0][1] == 4
    assert said[0][0] >= 14.0 + 10.0   # it waited for the vehicle to sink: SURFACE_WAIT_MS


def test_a_reset_of_a_disarmed_board_says_nothing_and_stays_disarmed():
    r = fly("watchdog@5", scenario="passive-drop", depth=2.0, duration=8.0)
    assert r["resets"] == 1
    assert "dive state: none kept" in r["console"]
    assert not [t for t in texts(r) if "resumed" in t or t.startswith(("Power lost", "Watchdog reset at"))]


@pytest.mark.micropython
def test_a_watchdog_reset_resumes_the_dive_on_micropython():
    r = fly("watchdog@20", interpreter="micropython")
    assert r["resets"] == 1
    assert r["landing_error_m"] < 0.5, r["landing_error_m"]
    assert resumed(r, "Watchdog reset at")


@pytest.mark.parametrize("interpreter", ["cpython", pytest.param("micropython", marks=pytest.mark.micropython)])
def test_a_reboot_the_ground_asked_for_is_no_lockup(interpreter):
    # The rp2 port's machine.reset() goes through the watchdog, so the next
    # boot reads WDT_RESET; the firmware marks a commanded reboot in the
    # scratch words first and the failsafes take it for what it is.
    from roboray.sim.twin.ground import Action
    r = fly(scenario="passive-drop", depth=2.0, duration=8.0, interpreter=interpreter,
            operator=[Action(4.0, "reboot", label="reboot", max_tries=1)])
    assert r["resets"] == 1
    assert any(line.endswith("(rebooted on command)") for line in r["console"]), r["console"]
    assert "watchdog reset" not in [f["name"] for f in r["failsafes"]]
    # the firmware says which build it is at each start, to the ground too
    banners = [t for t in texts(r) if t.startswith("RoboRay firmware")]
    assert len(banners) == 2


def test_a_lockup_after_a_commanded_reboot_is_a_lockup_again():
    from roboray.sim.twin.ground import Action
    r = fly("watchdog@6", scenario="passive-drop", depth=2.0, duration=12.0,
            operator=[Action(3.0, "reboot", label="reboot", max_tries=1)])
    assert r["resets"] == 2
    assert [f["name"] for f in r["failsafes"]].count("watchdog reset") == 1


def test_two_watchdog_faults_a_second_apart_are_two_resets():
    # the second comes as the first hang's watchdog fires: it hangs the loop
    # of the board that comes back, once that loop has started its watchdog
    r = fly("watchdog@20", "watchdog@21")
    assert r["resets"] == 2, r["resets"]
    assert resumed(r, "Watchdog reset at")
    assert r["modes"][-1][1] in ("TARGET", "FAILSAFE") and r["landing_error_m"] < 0.5, r["landing_error_m"]
