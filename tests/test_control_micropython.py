"""The controllers on the real MicroPython: the same wing commands as on
CPython, and a cascade step that allocates only its boxed floats, within
the figure ``roboray-sim bench control`` reports against."""

from __future__ import annotations

import json

import pytest

from roboray.shared import control as control_pkg
from roboray.shared.control import allocation, backstepping, cascade, gains
from roboray.shared.estimator import Estimator
from roboray.sim import controller_costs as costs
from roboray.sim import flight as F
from roboray.sim.commands.control import STEP_HEAP_LIMIT
from roboray.tools import boardcheck
from roboray.tools.micropython import assert_close_f32


@pytest.fixture(scope="module")
def target_log():
    """A TARGET flight with the estimator in the loop: the last held step
    and 4 s after the release."""
    spec = F.FlightSpec(mode="target", target=(1.5, -1.0), max_flight_s=4.0, seed=5)
    flight = F.fly(spec)
    return spec, flight


def _replay_on(mp, spec, log):
    mp.write_file("/tmp/ctl_cmp_log.json", json.dumps(log))
    mp.exec(F.CONTROL_REPLAY)
    mp.exec("import json\n__c = build_controller(*%s)\n" % json.dumps(list(F.controller_setup(spec))))
    return mp.eval("control_replay(__c, Estimator(), json.load(open('/tmp/ctl_cmp_log.json')))")


def test_replayed_steps_give_the_flight_commands_and_the_same_on_micropython(micropython, target_log):
    spec, flight = target_log
    log = flight.control_log
    assert log[0][1] == 1 and log[1][1] == 4   # held (PASSIVE), then TARGET
    ns = F.control_replay_namespace()
    on_cpython = ns["control_replay"](ns["build_controller"](*F.controller_setup(spec)), Estimator(), log)
    # the replay is the flight: the commands the dynamics got
    assert on_cpython[1:len(flight.command) + 1] == flight.command.tolist()[:len(on_cpython) - 1]
    on_micropython = _replay_on(micropython, spec, log)
    assert len(on_micropython) == len(log)
    assert_close_f32(on_cpython, on_micropython)
    # it steered: the wings left the symmetric fold
    spread = max(max(r) - min(r) for r in on_micropython)
    assert spread > 0.5


def test_backstepping_steps_agree_on_both_interpreters(micropython):
    spec = F.FlightSpec(controller="backstepping", mode="target", target=(2.0, 0.0), max_flight_s=1.0)
    log = F.fly(spec).control_log
    ns = F.control_replay_namespace()
    on_cpython = ns["control_replay"](ns["build_controller"](*F.controller_setup(spec)), Estimator(), log)
    assert_close_f32(on_cpython, _replay_on(micropython, spec, log))


@pytest.mark.parametrize("mode", sorted(costs.BENCH_FLIGHTS))
def test_a_cascade_step_allocates_within_the_bench_limit(micropython, mode):
    spec, log = costs.bench_log(mode, steps=60, warm=40)
    cost = costs.measure_on(micropython, spec, log, warm=40)
    each = cost["heap_bytes_each"]
    assert len(each) == 60
    # boxed floats only (16 bytes each), no container, within the limit
    assert all(b % 16 == 0 for b in each)
    assert 0 < cost["heap_bytes"] <= STEP_HEAP_LIMIT


#: Everything a cascade step runs: these must build no container, string or closure.
STEP_CODE = [
    cascade.Controller.step, cascade.Controller._descent, cascade.Controller._guidance,
    cascade.Controller._velocity, cascade.Controller._attitude, cascade.Controller._allocate,
    cascade.Controller._fixed, cascade.Controller._degraded, cascade.Controller.set_target,
    cascade.Controller.set_velocity, cascade.Controller.set_attitude, cascade.Controller.reset,
    allocation.Allocation.wings, allocation.Allocation.descent, allocation.Allocation.fold_for,
    allocation.Allocation._fold_index, allocation.Allocation._trilinear, allocation._clip,
    gains.Gains.refresh,
]
def _builds(func) -> list[str]:
    return boardcheck.step_builds(func)


@pytest.mark.parametrize("func", STEP_CODE, ids=lambda f: f.__qualname__)
def test_step_code_builds_no_container_string_or_closure(func):
    assert _builds(func) == []


def test_the_check_catches_a_returned_tuple():
    def bad(self, x):
        return x, 1

    assert "returned tuple" in " ".join(_builds(bad))


def test_package_docstring_documents_the_api():
    doc = control_pkg.__doc__
    for name in ("Controller(params)", "set_target(north, east)", "set_velocity(v_north, v_east, v_down)",
                 "set_attitude(roll, pitch, yaw)", "reset()", "step(t_us, mode, est, out)", "command",
                 "roboray-sim bench control"):
        assert name in doc, name
    for method in ("set_target", "set_velocity", "set_attitude", "reset", "step"):
        assert callable(getattr(backstepping.BacksteppingController, method))
