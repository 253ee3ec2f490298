"""Each failsafe, injected in the twin, ends in its action and is reported.

The firmware runs unchanged (``--interpreter cpython``: the failsafes'
logic, not the interpreter, is the point here; the MicroPython runs are in
``test_sil_twin.py``) on the emulated board in lockstep with the dynamics;
faults come through the emulated parts (a NACK on the I2C bus, a pin, the
ADC, bytes lost on the radio). "Reported" is checked where an operator sees
it: STATUSTEXT and SYS_STATUS ``errors_count1`` decoded by pymavlink on the
ground side, and the mode in the vehicle's heartbeats. Dives are short: a
passive drop in 4 m of water, released at about 9.6 s, on the bottom at
about 19 s.
"""

from __future__ import annotations

import pytest

from roboray.firmware import failsafe as F
from roboray.sim.twin import faults
from roboray.sim.twin.ground import Action
from roboray.sim.twin.runner import Options, run


def fly(*fault_specs, params=None, duration=22.0, depth=4.0, operator=()):
    return run(Options(scenario="passive-drop", interpreter="cpython", depth=depth, duration=duration,
                       faults=[faults.parse(f) for f in fault_specs], params=dict(params or {}),
                       operator=list(operator)))


def names(report):
    return [f["name"] for f in report["failsafes"]]


def first(report, name):
    return next(f["t"] for f in report["failsafes"] if f["name"] == name)


def texts(report):
    return [t[2] for t in report["statustext"]]


def modes_since(report, t):
    return [m for when, m in report["modes"] if when >= t]


def arming_since(report, t):
    return [a for when, a in report["arming"] if when >= t]


def reported(report, bit):
    return bool(report["failsafe_flags_reported"] & (1 << bit))


def test_a_leak_puts_the_vehicle_in_failsafe_mode_and_says_so():
    # the operator tries to leave FAILSAFE while the leak lasts (latched): refused, named
    r = fly("leak@13", operator=[Action(15.0, "mode", ("PASSIVE",), max_tries=1)])
    assert names(r) == ["leak"]
    assert 13.0 <= first(r, "leak") <= 13.5          # three 50 ms samples of debounce, 10 Hz evaluation
    assert modes_since(r, 13.0) == ["FAILSAFE"] and arming_since(r, 13.0) == []
    assert "Failsafe: leak, FAILSAFE mode" in texts(r)
    assert r["operator"][-1]["result"].startswith("refused")
    assert "FAILSAFE held: leak" in texts(r) and "in FAILSAFE until its cause clears (or disarm)" in texts(r)
    assert reported(r, F.LEAK)
    assert r["landed"]


@pytest.mark.parametrize("fault", ["depth-nack", "depth-garbage", "depth-stick"])
def test_a_failing_depth_sensor_is_caught_by_what_it_does(fault):
    # NACK: bus errors; garbage: plausible-looking pressures the estimator's
    # gate refuses; stuck: a depth that stops while the accelerometer says
    # the vehicle still falls.
    r = fly("%s@13" % fault)
    assert names(r)[0] == "depth sensor"
    assert 13.0 <= first(r, "depth sensor") <= 14.0
    assert modes_since(r, 13.0)[0] == "FAILSAFE"
    assert "Failsafe: depth sensor, FAILSAFE mode" in texts(r)
    assert reported(r, F.DEPTH)


def test_an_imu_that_stops_answering_is_reported_and_the_estimator_failsafe_acts():
    # FS_SENSOR_ACT 1: the IMU failure only warns; the estimate it leaves
    # invalid is FS_EKF_ACTION's (3, FAILSAFE mode) a second later.
    r = fly("imu-nack@13", params={"FS_SENSOR_ACT": 1})
    assert names(r)[:2] == ["IMU", "estimator"]
    # the IMU's failsafe counts it after SENSOR_CONFIRM_MS (0.2 s), the
    # estimator's a second after the estimate went invalid
    assert 13.0 + F.SENSOR_CONFIRM_MS / 1000 <= first(r, "IMU") <= 13.5
    assert 0.7 <= first(r, "estimator") - first(r, "IMU") <= 1.1
    assert "Failsafe: IMU, warning" in texts(r)
    assert "Failsafe: estimator, FAILSAFE mode" in texts(r)
    assert modes_since(r, 13.0)[0] == "FAILSAFE"
    assert reported(r, F.IMU) and reported(r, F.EKF)


@pytest.mark.parametrize("fault, name, bit", [("imu-stick", "IMU", "IMU"), ("mag-stick", "compass", "COMPASS")])
def test_a_sensor_whose_outputs_freeze_mid_descent_is_caught(fault, name, bit):
    # The part goes on answering and flagging new samples, its counts stop
    # moving while the vehicle falls steadily (nothing else looks wrong): a
    # live part's noise never repeats every count twenty samples in a row.
    r = fly("%s@10" % fault)
    assert names(r)[0] == name
    # twenty frozen samples, SENSOR_CONFIRM_MS, and a planned collection's
    # stall (the loop reads no sensor during it) that may fall among them
    from roboray.firmware import app
    assert 10.0 <= first(r, name) <= 10.6 + app.GC_STALL_MS / 1000
    assert reported(r, getattr(F, bit))
    assert r["landed"] is False or first(r, name) < r["landed_at_s"]


def test_warnings_change_nothing_but_are_reported_and_an_action_set_off_raises_nothing():
    # 300 us a clock reading on top of the tasks' own board time: the loop
    # overruns, short of starving the watchdog
    r = fly("mag-garbage@12", "battery-sag@12", "overload:300@15", "leak@16",
            params={"BATT_LOW_TIMER": 2, "FS_DEPTH_MAX": 2.0, "FS_LEAK_ENABLE": 0})
    assert set(names(r)) == {"compass", "battery low", "loop overruns", "max depth"}
    # the pack crosses 6.6 V 1.6 s into the sag, the driver's 1 s filter a
    # second later, then BATT_LOW_TIMER (2 s); the overload from 15 s makes
    # every clock reading cost 300 us, so the loop's overrun slots (and the
    # battery task with them) run late by a few tenths
    assert 16.0 <= first(r, "battery low") <= 18.0
    for name in ("compass", "battery low", "loop overruns", "max depth"):
        assert "Failsafe: %s, warning" % name in texts(r)
    for bit in (F.COMPASS, F.BATTERY, F.OVERRUN, F.MAX_DEPTH):
        assert reported(r, bit)
    assert not reported(r, F.LEAK)
    assert [m for _, m in r["modes"]] == ["PASSIVE"]
    assert r["overruns"] > 0 and r["resets"] == 0


def test_a_lost_link_holds_the_safe_configuration_and_its_end_is_reported():
    # once the link is back (the failsafe's cause gone) the operator takes over
    r = fly("radio-loss@12", "radio-ok@18", params={"FS_GCS_ENABLE": 3},
            operator=[Action(19.0, "mode", ("PASSIVE",))])
    assert names(r) == ["link lost"]
    assert 15.5 <= first(r, "link lost") <= 17.5     # FS_GCS_TIMEOUT 5 s after the last heartbeat
    assert modes_since(r, 15.0) == ["FAILSAFE", "PASSIVE"]
    assert r["operator"][-1]["result"] == "accepted" and r["operator"][-1]["t"] >= 19.0
    # the trigger's text went into the void; the end of it and the mode did not
    assert "Failsafe cleared: link lost" in texts(r)
    assert r["failsafes_cleared"][0]["name"] == "link lost"


def test_a_corrupted_link_counts_as_lost_and_can_disarm():
    r = fly("radio-corrupt:0.5@12", params={"FS_GCS_ENABLE": 2})
    assert names(r) == ["link lost"]
    assert arming_since(r, 15.0) == ["disarmed"] and modes_since(r, 15.0) == []   # the mode stays
    assert r["bad_frames_from_vehicle"] > 10


def test_a_hung_loop_is_reset_by_the_watchdog_and_reported_after_the_reset():
    r = fly("watchdog@12", params={"FS_LOCKUP_ACT": 3})
    assert r["resets"] == 1
    boot = [line for line in r["console"] if line.startswith("reset cause")]
    assert boot == ["reset cause: PWRON_RESET", "reset cause: WDT_RESET"]
    assert names(r)[0] == "watchdog reset"
    assert 14.9 <= first(r, "watchdog reset") <= 15.3   # 1 s watchdog, 2 s start-up grace
    # under water the board resumes its dive (firmware/resume.py): armed in
    # PASSIVE again, and FS_LOCKUP_ACT acts on the resumed dive, whether the
    # resume or the failsafe's report comes first
    assert arming_since(r, 12.0) == ["disarmed", "armed"]
    after = modes_since(r, 12.0)
    assert after[-1] == "FAILSAFE" and set(after) <= {"OFF", "PASSIVE", "FAILSAFE"}
    assert "Failsafe: watchdog reset, FAILSAFE mode" in texts(r)
    assert reported(r, F.LOCKUP)


def test_an_overloaded_loop_starves_the_watchdog():
    # 3 ms a clock reading: every slot overruns, the sensors' data go stale,
    # and after 25 overrunning slots the scheduler stops feeding the watchdog
    r = fly("overload:3000@12", duration=18.0)
    assert r["overruns"] >= 25 and r["resets"] == 1
    assert "reset cause: WDT_RESET" in r["console"]
    assert {"loop overruns", "watchdog reset"} <= set(names(r))
    assert first(r, "loop overruns") < first(r, "watchdog reset")


def test_a_leak_on_deck_is_reported_and_refuses_arming():
    # ArduSub's rule: disarmed, a failsafe warns (the servos are at the safe
    # position already); the arming check refuses with the reason
    r = fly("leak@4", duration=14.0)
    assert names(r)[0] == "leak"
    assert "Failsafe: leak, warning" in texts(r)
    assert [m for _, m in r["modes"]] == ["PASSIVE"] and [a for _, a in r["arming"]] == ["disarmed"]
    assert r["operator"][0]["result"].startswith("refused") and "leak detected" in texts(r)
    assert r["released_at_s"] is None


def test_arming_is_refused_with_the_reason():
    r = fly("depth-nack@4", duration=14.0)
    assert names(r) == ["depth sensor"]               # reported; no action while disarmed
    arm = r["operator"][0]
    assert arm["action"] == "arm" and arm["result"].startswith("refused")
    assert "sensor fault" in texts(r)                 # the refusal's reason, as a STATUSTEXT
    assert [m for _, m in r["modes"]] == ["PASSIVE"] and [a for _, a in r["arming"]] == ["disarmed"]
    assert r["released_at_s"] is None


def test_a_power_cut_and_an_unhealthy_sensor_at_boot_are_not_mistaken_for_each_other():
    # after a power cut the vehicle boots again, disarmed, and stays quiet
    r = fly("powercut@12", duration=17.0)
    assert r["power_cuts"] == 1 and r["failsafes"] == []
    assert sum(1 for line in r["console"] if line.startswith("running:")) == 2


def test_operator_actions_reach_the_firmware():
    r = fly(operator=[Action(3.0, "param", ("FS_GCS_TIMEOUT", 7.0)),
                      Action(4.0, "param_read", ("SR_STATUS",))], duration=6.0)
    results = {a["action"]: a["result"] for a in r["operator"]}
    assert results["param"] == "7" and results["param_read"] == "1"


def test_an_imu_that_sticks_and_recovers_raises_only_its_own_failsafe():
    # Issue 16: the estimator held the frozen IMU's attitude through the
    # failsafe's wing fold; when the IMU came back, gravity leaking through
    # the stale tilt made ~0.9 m/s^2 of false vertical acceleration, the
    # depth gate refused good pressures and the depth failsafe latched.
    # Now the estimator coasts without its IMU and levels again from
    # gravity when it returns: the depth sensor is not blamed.
    r = fly("imu-stick@13", "imu-ok@16")
    assert names(r) == ["IMU"]
    assert not reported(r, F.DEPTH) and not reported(r, F.EKF) and r["landed"]


def test_a_stall_as_long_as_a_flash_save_trips_no_sensor_failsafe():
    # A flash save stalls the chip up to 150 ms (flash_record.SAVE_STALL_MS);
    # after it the IMU's FIFO holds more than a read takes and every driver's
    # last sample is older than its time-out, so a slot or two read
    # unhealthy with nothing wrong. The failsafes wait SENSOR_CONFIRM_MS
    # before they count a sensor: the dive goes on in TARGET and lands.
    # at these times the failsafes' 10 Hz evaluation falls in the slots
    # after a stall (without the confirmation the IMU failsafe acted)
    stalls = ["stall:150@%g" % t for t in (11.013, 12.023, 13.033, 14.03, 15.04)]
    r = run(Options(scenario="target-landing", interpreter="cpython",
                    faults=[faults.parse(f) for f in stalls]))
    assert r["failsafes"] == []
    assert "FAILSAFE" not in [m for _, m in r["modes"]]
    assert r["landing_error_m"] < 0.25
    assert r["skipped_slots"] >= 5 * 14    # each stall missed its slots


def test_a_stall_fault_is_checked():
    assert faults.parse("stall@3").arg == 150
    for bad in ("stall:0@3", "stall:1000@3", "stall:2.5@3"):
        with pytest.raises(ValueError, match="stall"):
            faults.parse(bad)


def test_a_low_pack_disarmed_parks_the_servos_and_arming_is_refused(tmp_path):
    # the pack sags on the bottom; BATT_FS_LOW_ACT 2 disarms the resting
    # vehicle, and disarmed with a low pack its servos get no pulses
    # (BATT_PARK 1, the default): SERVO_OUTPUT_RAW reads 0 on the ground
    from pymavlink import mavutil

    tlog = tmp_path / "park.tlog"
    r = run(Options(scenario="bottom-rest", interpreter="cpython", duration=30.0,
                    faults=[faults.parse("battery-sag@16")], params={"BATT_LOW_TIMER": 2, "BATT_FS_LOW_ACT": 2},
                    tlog=str(tlog)))
    assert r["landed_at_s"] < 16.0 and names(r) == ["battery low"]
    low = first(r, "battery low")
    assert arming_since(r, low) == ["disarmed"]
    assert "Battery low: servos parked (disarmed)" in texts(r)
    parked = next(t for t, _, text in r["statustext"] if text.startswith("Battery low: servos parked"))
    assert low <= parked <= low + 1.0                      # the next evaluation, 10 Hz, and the link
    outputs = []
    m = mavutil.mavlink_connection(str(tlog))
    while True:
        msg = m.recv_match(type="SERVO_OUTPUT_RAW")
        if msg is None:
            break
        outputs.append((msg.time_usec / 1e6, [msg.servo1_raw, msg.servo2_raw, msg.servo3_raw, msg.servo4_raw]))
    before = [o for t, o in outputs if t < low - 0.5]
    after = [o for t, o in outputs if t > parked + 0.5]
    assert before and all(min(o) > 0 for o in before)          # held, pulses going out
    assert after and all(o == [0, 0, 0, 0] for o in after)      # parked: none


def test_the_servos_hold_on_a_low_pack_with_park_off():
    r = fly("battery-sag@12", params={"BATT_LOW_TIMER": 2, "BATT_FS_LOW_ACT": 2, "BATT_PARK": 0})
    assert names(r) == ["battery low"]
    assert not any(text.startswith("Battery low: servos parked") for text in texts(r))
