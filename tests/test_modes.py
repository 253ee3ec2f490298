"""Mode logic: arming is a flag, the mode stays; the checks; leaving FAILSAFE;
the MAVLink numbers and names."""

from __future__ import annotations

import pytest
from pymavlink import mavutil

from roboray.shared import modes as M


class Checks:
    def __init__(self):
        self.arming = None
        self.mode = {}
        self.held = None
        self.mode_checked = []

    def arming_check(self):
        return self.arming

    def mode_check(self, mode):
        self.mode_checked.append(mode)
        return self.mode.get(mode)

    def failsafe_held(self):
        return self.held


def armed(checks=None):
    m = M.Modes(checks)
    assert m.arm() == M.ACCEPTED
    return m


def test_boots_disarmed_in_passive_and_any_mode_may_be_chosen_disarmed():
    c = Checks()
    c.mode[M.TARGET] = M.NO_TARGET
    m = M.Modes(c)
    assert (m.mode, m.armed, m.state) == (M.PASSIVE, False, M.DISARMED)
    for mode in (M.ATTITUDE, M.VELOCITY, M.TARGET, M.FAILSAFE, M.PASSIVE):
        assert m.request(mode) == M.ACCEPTED and m.mode == mode and not m.armed
        assert m.state == M.DISARMED
    assert c.mode_checked == []   # ArduCopter's rule: a disarmed vehicle's checks come at arming
    assert m.changes == 5


def test_arming_keeps_the_mode_and_checks_the_mode_it_arms_in():
    c = Checks()
    c.mode[M.TARGET] = M.NO_TARGET
    m = M.Modes(c)
    m.request(M.TARGET)
    assert m.arm() == (False, M.NO_TARGET) and not m.armed
    c.arming = M.LEAK
    assert m.arm() == (False, M.LEAK)
    assert m.arm(force=True) == M.ACCEPTED and m.armed and m.mode == M.TARGET and m.state == M.TARGET
    assert m.arms == 1
    assert m.arm() == M.ACCEPTED and m.arms == 1        # arming an armed vehicle: accepted, nothing new
    assert m.disarm() == M.ACCEPTED and m.mode == M.TARGET and not m.armed and m.state == M.DISARMED
    assert m.disarm() == M.ACCEPTED


def test_armed_mode_changes_pass_the_mode_check():
    c = Checks()
    c.mode[M.TARGET] = M.NO_TARGET
    m = armed(c)
    for mode in (M.ATTITUDE, M.VELOCITY, M.PASSIVE, M.VELOCITY):
        assert m.request(mode) == M.ACCEPTED and m.mode == mode == m.state
    assert m.request(M.TARGET) == (False, M.NO_TARGET) and m.mode == M.VELOCITY
    assert m.last_refusal == M.NO_TARGET
    del c.mode[M.TARGET]
    assert m.request(M.TARGET) == M.ACCEPTED and m.intended == M.TARGET


@pytest.mark.parametrize("start", M.MODES)
@pytest.mark.parametrize("is_armed", [False, True])
def test_a_failsafe_reaches_failsafe_from_every_mode(start, is_armed):
    m = M.Modes()
    m.request(start)
    if is_armed:
        m.arm()
    assert m.failsafe(M.LEAK) == M.ACCEPTED and m.mode == M.FAILSAFE and m.failsafe_cause == M.LEAK
    assert m.armed == is_armed and m.intended == start   # what the operator chose stays intended


def test_failsafe_is_left_once_its_cause_has_cleared():
    c = Checks()
    m = armed(c)
    m.request(M.TARGET)
    m.failsafe(M.LOW_BATTERY)
    c.held = M.IN_FAILSAFE
    for mode in (M.PASSIVE, M.ATTITUDE, M.VELOCITY, M.TARGET):
        assert m.request(mode) == (False, M.IN_FAILSAFE) and m.mode == M.FAILSAFE
    assert m.request(M.FAILSAFE) == M.ACCEPTED        # staying is no change
    assert m.disarm() == M.ACCEPTED and m.mode == M.FAILSAFE
    assert m.request(M.PASSIVE) == M.ACCEPTED          # disarmed: chosen freely, the arming checks judge
    m.arm()
    m.request(M.FAILSAFE)
    c.held = None                                      # the cause is gone
    assert m.request(M.TARGET) == M.ACCEPTED and m.mode == M.TARGET


def test_failsafe_the_operator_chose_is_left_freely():
    # (the firmware's failsafe_held() holds only what a failsafe switched)
    m = armed()
    assert m.request(M.FAILSAFE) == M.ACCEPTED and m.failsafe_cause == M.OK
    assert m.request(M.TARGET) == M.ACCEPTED


def test_unknown_modes_are_refused():
    m = armed()
    for bad in (-1, M.DISARMED, 6, 17):
        assert m.request(bad) == (False, M.UNKNOWN_MODE)
    assert m.mode == M.PASSIVE


def test_restore_puts_back_mode_and_arming_without_checks():
    c = Checks()
    c.arming = M.SENSOR_FAULT
    m = M.Modes(c)
    assert m.restore(M.TARGET, True) and m.armed and m.mode == M.TARGET and m.arms == 0
    assert not m.restore(M.PASSIVE, True)              # armed since: someone chose
    assert not M.Modes().restore(M.DISARMED, True)


def test_heartbeat_numbers_are_ardusubs_and_name_what_each_mode_does():
    """pymavlink names a MAV_TYPE_SUBMARINE's custom_mode from ArduSub's table,
    as MAVProxy shows it; each mode has a name there, and that name maps back."""
    names = mavutil.mode_mapping_bynumber(mavutil.mavlink.MAV_TYPE_SUBMARINE)
    byname = mavutil.mode_mapping_byname(mavutil.mavlink.MAV_TYPE_SUBMARINE)
    shown = {M.NAMES[m]: names[M.CUSTOM[m]] for m in M.MODES}
    assert shown == {"PASSIVE": "MANUAL", "ATTITUDE": "STABILIZE", "VELOCITY": "GUIDED", "TARGET": "AUTO",
                     "FAILSAFE": "SURFACE"}
    for m in M.MODES:
        assert M.ARDUSUB_NAMES[m] == shown[M.NAMES[m]]
        assert M.from_custom(byname[M.ARDUSUB_NAMES[m]]) == m
        assert M.mode_number(M.NAMES[m].lower()) == m == M.mode_number(M.ARDUSUB_NAMES[m].lower())
        assert M.custom_name(M.CUSTOM[m]) == M.NAMES[m]
    assert M.from_custom(1) == -1 and M.custom_name(1) == "MODE 1"   # ACRO: none of ours
    assert M.mode_number("DISARMED") == -1 and M.mode_number("nope") == -1
    assert M.from_standard(mavutil.mavlink.MAV_STANDARD_MODE_MISSION) == M.TARGET
    assert M.from_standard(mavutil.mavlink.MAV_STANDARD_MODE_NON_STANDARD) == -1


def test_heartbeat_flags():
    m = M.Modes()
    assert (m.custom_mode(), m.base_mode(), m.system_status()) == (19, 1, 3)   # MANUAL, standby
    m.request(M.TARGET)
    assert m.base_mode() == 1 | 8 | 16 and m.system_status() == 3               # disarmed: standby
    m.arm()
    assert (m.custom_mode(), m.base_mode(), m.system_status()) == (3, 1 | 8 | 16 | 128, 4)
    m.request(M.ATTITUDE)
    assert m.base_mode() == 1 | 16 | 128
    m.failsafe(M.LEAK)
    assert (m.custom_mode(), m.system_status()) == (9, 5)


def test_requests_allocate_nothing_on_micropython(micropython):
    setup = (
        "from roboray.shared import modes as M\n__m = M.Modes()\n__m.arm()\n"
        "def __flip():\n    a = __m.request(M.ATTITUDE)\n    b = __m.request(M.from_custom(4))\n"
        "    c = __m.request(17)\n    d = __m.disarm()\n    e = __m.arm()\n"
        "    return a[0] and b[0] and not c[0] and d[0] and e[0] and __m.mode == M.VELOCITY\n"
    )
    assert micropython.alloc_bytes("__flip()", setup) == 0
    assert micropython.eval("__flip()") is True
