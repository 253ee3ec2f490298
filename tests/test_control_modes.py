"""The controller under the mode logic: what the wings do in each mode,
armed and disarmed, through accepted and refused transitions, FAILSAFE from
every mode, the integrators' reset, an invalid estimate, parameters changed
in flight."""

from __future__ import annotations

import math
from array import array

import pytest

from roboray.shared import modes as M
from roboray.shared import param_defs
from roboray.shared.control import Controller, gains
from roboray.shared.control.backstepping import BacksteppingController
from roboray.shared.estimator import Estimator
from roboray.shared.estimator import health as H
from roboray.shared.params import ParamTable

STEP_US = 20000


class Checks:
    """The firmware's checks: TARGET needs a target; FAILSAFE a failsafe chose is held while ``held``."""

    def __init__(self, ctl):
        self.ctl = ctl
        self.held = None

    def arming_check(self):
        return None

    def mode_check(self, mode):
        return M.NO_TARGET if mode == M.TARGET and not self.ctl.target_set else None

    def failsafe_held(self):
        return self.held


def flying_estimate(descent=0.44):
    """A real estimator whose outputs say: valid, level, descending."""
    est = Estimator()
    est.status[H.STATUS_HEALTH] = H.IMU_OK | H.DEPTH_OK | H.FIX_OK | H.ATTITUDE_VALID | H.DEPTH_VALID \
        | H.POSITION_VALID
    est.status[H.STATUS_VALID] = 1
    est.nav[H.NAV_DEPTH] = 3.0
    est.nav[H.NAV_VZ] = descent
    return est


@pytest.fixture
def table():
    t = ParamTable(param_defs.PARAMS)
    assert t.set_by_name("SERVO_SAFE_DEG", 10.0) == 0
    assert t.set_by_name("PASSIVE_WING_DEG", 30.0) == 0
    assert t.set_by_name("FS_WING_DEG", 80.0) == 0
    return t


class Vehicle:
    """Mode logic and controller stepped together, as the firmware does."""

    def __init__(self, table, kind=Controller):
        self.ctl = kind(table)
        self.modes = M.Modes(Checks(self.ctl))
        self.est = flying_estimate()
        self.out = array("f", [0.0] * 4)
        self.t = 0

    def step(self, n=1):
        for _ in range(n):
            self.t += STEP_US
            self.ctl.step(self.t, self.modes.state, self.est, self.out)
        return [round(math.degrees(v), 3) for v in self.out]


@pytest.mark.parametrize("kind", [Controller, BacksteppingController])
def test_fixed_modes_write_their_configured_wings(table, kind):
    v = Vehicle(table, kind)
    assert v.step() == [10.0] * 4                      # disarmed: the safe position
    assert v.modes.request(M.FAILSAFE) == M.ACCEPTED   # any mode, disarmed: still the safe position
    assert v.step() == [10.0] * 4
    assert v.modes.request(M.PASSIVE) == M.ACCEPTED
    assert v.modes.arm() == M.ACCEPTED
    assert v.step() == [30.0] * 4                      # PASSIVE
    assert v.modes.request(M.TARGET) == (False, M.NO_TARGET)
    v.ctl.set_target(2.0, 0.0, 10.0)
    assert v.modes.request(M.TARGET) == M.ACCEPTED
    steered = v.step(50)
    if kind is Controller:
        assert max(steered) - min(steered) > 5.0       # TARGET: it folds one side
    else:
        assert steered != [30.0] * 4                   # the thesis's law acts (it does not steer)
    assert v.modes.failsafe(M.LEAK) == M.ACCEPTED
    assert v.step() == [80.0] * 4                      # FAILSAFE: the configured fold, at once
    v.modes.checks.held = M.IN_FAILSAFE                # the leak lasts
    assert v.modes.request(M.PASSIVE) == (False, M.IN_FAILSAFE)
    assert v.step() == [80.0] * 4
    v.modes.checks.held = None
    assert v.modes.request(M.PASSIVE) == M.ACCEPTED
    assert v.step() == [30.0] * 4
    assert v.modes.disarm() == M.ACCEPTED and v.modes.mode == M.PASSIVE
    assert v.step() == [10.0] * 4


@pytest.mark.parametrize("start", [M.PASSIVE, M.ATTITUDE, M.VELOCITY, M.TARGET])
def test_failsafe_from_every_mode_folds_the_wings(table, start):
    v = Vehicle(table)
    v.ctl.set_target(1.0, 1.0)
    v.modes.arm()
    assert v.modes.request(start) == M.ACCEPTED
    v.step(20)
    assert v.modes.request(M.FAILSAFE) == M.ACCEPTED
    assert v.step() == [80.0] * 4


def test_an_unknown_mode_number_gets_the_failsafe_wings(table):
    v = Vehicle(table)
    v.ctl.step(STEP_US, 17, v.est, v.out)
    assert [round(math.degrees(x), 3) for x in v.out] == [80.0] * 4
    assert v.modes.request(17) == (False, M.UNKNOWN_MODE)


def test_without_a_valid_estimate_it_holds_the_passive_wings(table):
    v = Vehicle(table)
    v.modes.arm()
    v.ctl.set_velocity(0.1, 0.0, 0.0)
    v.modes.request(M.VELOCITY)
    v.est.status[H.STATUS_VALID] = 0
    assert v.step() == [30.0] * 4 and v.ctl.degraded
    v.est.status[H.STATUS_VALID] = 1
    v.step(30)
    assert not v.ctl.degraded and v.ctl.command[3] > 0.05   # gliding north (heading 0: +x)


def test_a_mode_change_clears_the_integrators(table):
    v = Vehicle(table)
    v.modes.arm()
    v.ctl.set_velocity(0.0, 0.0, 0.38)
    v.est.nav[H.NAV_VZ] = 0.30                           # too slow: the descent integrator winds
    v.modes.request(M.VELOCITY)
    v.step(100)
    wound = v.ctl._i[0]
    assert wound > 0.05
    v.modes.request(M.TARGET)    # refused (no target): nothing changes
    assert v.ctl._i[0] == wound
    v.ctl.set_target(0.0, 0.0)
    v.modes.request(M.TARGET)
    v.step()
    assert v.ctl._i[0] == 0.0


def test_a_parameter_set_in_flight_is_used_at_the_next_step(table):
    v = Vehicle(table)
    v.modes.arm()
    assert v.step() == [30.0] * 4
    assert table.set_by_name("PASSIVE_WING_DEG", 50.0) == 0
    assert v.step() == [50.0] * 4
    assert table.set_by_name("CTL_SLEW_DPS", 5000.0) != 0    # out of range: refused, nothing changes
    assert v.ctl.gains.k[gains.SLEW] == pytest.approx(math.radians(60.0), rel=1e-6)
