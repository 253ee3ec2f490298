"""Mode logic: the transition table, arming, failsafe from everywhere."""

from __future__ import annotations

import pytest

from roboray.shared import modes as M


class Checks:
    def __init__(self):
        self.arming = None
        self.mode = {}

    def arming_check(self):
        return self.arming

    def mode_check(self, mode):
        return self.mode.get(mode)


def armed(checks=None):
    m = M.Modes(checks)
    assert m.arm() == M.ACCEPTED
    return m


def test_starts_disarmed_and_flight_modes_need_arming():
    m = M.Modes()
    assert m.mode == M.DISARMED and not m.armed
    for mode in (M.PASSIVE, M.ATTITUDE, M.VELOCITY, M.TARGET):
        assert m.request(mode) == (False, M.NOT_ARMED)
    assert m.mode == M.DISARMED and m.changes == 0


def test_arming_lands_in_passive_and_checks_can_refuse():
    c = Checks()
    c.arming = M.LEAK
    m = M.Modes(c)
    assert m.arm() == (False, M.LEAK) and m.mode == M.DISARMED
    assert m.arm(force=True) == M.ACCEPTED and m.mode == M.PASSIVE and m.armed
    assert m.arm() == (False, M.ALREADY_ARMED)


def test_flight_modes_switch_freely_and_mode_checks_apply():
    c = Checks()
    c.mode[M.TARGET] = M.NO_TARGET
    m = armed(c)
    for mode in (M.ATTITUDE, M.VELOCITY, M.PASSIVE, M.VELOCITY):
        assert m.request(mode) == M.ACCEPTED and m.mode == mode
    assert m.request(M.TARGET) == (False, M.NO_TARGET) and m.mode == M.VELOCITY
    del c.mode[M.TARGET]
    assert m.request(M.TARGET) == M.ACCEPTED


@pytest.mark.parametrize("start", range(len(M.NAMES)))
def test_failsafe_is_reachable_from_every_mode(start):
    m = M.Modes()
    m.mode = start
    assert m.failsafe(M.LEAK) == M.ACCEPTED and m.mode == M.FAILSAFE and m.failsafe_cause == M.LEAK
    m.mode = start
    assert m.request(M.FAILSAFE) == M.ACCEPTED and m.mode == M.FAILSAFE


def test_failsafe_is_left_only_for_passive_or_disarmed():
    m = armed()
    m.failsafe(M.LOW_BATTERY)
    for mode in (M.ATTITUDE, M.VELOCITY, M.TARGET):
        assert m.request(mode) == (False, M.IN_FAILSAFE)
    assert m.request(M.PASSIVE) == M.ACCEPTED
    m.failsafe(M.OK)
    assert m.request(M.DISARMED) == M.ACCEPTED and not m.armed


def test_every_transition_agrees_with_the_table():
    for start in range(len(M.NAMES)):
        for goal in range(len(M.NAMES)):
            m = M.Modes()
            m.mode = start
            ok, reason = m.request(goal)
            allowed = goal == start or (M.TRANSITIONS[start] >> goal) & 1
            assert ok == bool(allowed), (M.NAMES[start], M.NAMES[goal], reason)
            assert reason in M.REASONS
            assert m.mode == (goal if ok else start)
    assert M.Modes().request(17) == (False, M.UNKNOWN_MODE)


def test_heartbeat_mapping():
    m = M.Modes()
    assert (m.custom_mode(), m.base_mode(), m.system_status()) == (0, 1, 3)  # custom mode, standby
    m.arm()
    assert m.base_mode() == 1 | 128 and m.system_status() == 4
    m.request(M.TARGET)
    assert m.custom_mode() == 4 and m.base_mode() == 1 | 8 | 16 | 128
    m.failsafe(M.LEAK)
    assert m.system_status() == 5
    assert M.mode_number("velocity") == M.VELOCITY and M.mode_number("nope") == -1


def test_requests_allocate_nothing_on_micropython(micropython):
    setup = (
        "from roboray.shared import modes as M\n__m = M.Modes()\n__m.arm()\n"
        "def __flip():\n    a = __m.request(M.ATTITUDE)\n    b = __m.request(M.VELOCITY)\n"
        "    c = __m.request(17)\n    return a[0] and b[0] and not c[0]\n"
    )
    assert micropython.alloc_bytes("__flip()", setup) == 0
    assert micropython.eval("__flip()") is True
