"""The estimator on the real MicroPython: the same answers as on CPython,
and steps that allocate only their boxed floats, within the bench's figure."""

from __future__ import annotations

import json

import pytest

from roboray.shared import estimator as estimator_pkg
from roboray.shared.estimator import attitude, descent_model, estimator, horizontal, ticks, vertical
from roboray.sim import estimation as E
from roboray.tools import boardcheck
from roboray.tools.micropython import assert_close_f32

#: Ticks replayed on both interpreters: 11 s, through the release at 10 s.
TICKS = 1100


@pytest.fixture(scope="module")
def prepared():
    truth = E.standard_truth(3)
    return E.prepare(truth, 3)


def test_same_log_gives_the_same_estimates_on_both_interpreters(micropython, prepared):
    calls = prepared.calls[:TICKS]
    on_cpython = E.run(prepared.config, calls, prepared.t[:TICKS], every=10)
    micropython.write_file("/tmp/est_cmp_cfg.json", json.dumps(prepared.config))
    micropython.write_file("/tmp/est_cmp_log.json", json.dumps(calls))
    micropython.exec(E.REPLAY)
    snaps = micropython.eval(
        "replay(build(__import__('json').load(open('/tmp/est_cmp_cfg.json'))), "
        "__import__('json').load(open('/tmp/est_cmp_log.json')), 10)")
    on_micropython = E.Estimates.from_snapshots(on_cpython.t, snaps)
    assert len(snaps) == TICKS // 10
    for name in ("q", "euler", "nav", "rates", "cov", "innovation"):
        assert_close_f32(getattr(on_cpython, name).tolist(), getattr(on_micropython, name).tolist())
    assert on_cpython.status.tolist() == on_micropython.status.tolist()
    # it really flew: released, descending, and valid
    assert on_micropython.nav[-1, 1] > 0.2
    assert on_micropython.status[-1, 1] == 1


def test_step_costs_stay_within_the_bench_figures(micropython, prepared):
    warm, measured = 1000, 100
    costs = E.micropython_costs(prepared.config, prepared.calls, warm=warm, measured=measured, mp=micropython)
    assert costs["micropython_bytes_per_step"] <= 4000
    assert costs["estimated_board_ms_per_step"] <= 2.0
    # every kind of job happened and was measured (a step without a job is
    # rare: the magnetometer's 155 Hz leaves one pending nearly every step)
    assert {"imu+fix", "imu+depth", "imu+housekeeping", "imu+mag"} <= set(costs["by_job"])
    assert max(v["bytes"] for v in costs["by_job"].values()) == costs["micropython_bytes_per_step"]
    # two more all-arrive ticks after the estimator's last tick: alloc_bytes
    # warms up on the first and measures the second
    cycle = E.all_arrive(prepared.calls[:warm + 2 * measured])
    last = [list(ev) for ev in cycle[-1]]
    last[-1][1] = micropython.eval("__est._t_imu")
    first = E.all_arrive(cycle[:-1] + [last], follow=0)
    second = E.all_arrive(cycle + first, follow=0)
    micropython.exec("__T = %s\n__i = -1\n"
                     "def nxt():\n    global __i\n    __i += 1\n    feed(__est, __T[__i])\n"
                     % json.dumps(first + second))
    nbytes = micropython.alloc_bytes("nxt()")
    assert micropython.eval("__i") == 1
    # boxed floats only: 16 bytes each, within the bench's figure
    assert nbytes % 16 == 0
    assert 0 < nbytes <= costs["micropython_bytes_per_step"]


#: Everything a step runs: these must build no container, string or closure.
STEP_CODE = [
    estimator.Estimator.imu, estimator.Estimator.mag, estimator.Estimator.depth,
    estimator.Estimator.fix, estimator.Estimator.wings, estimator.Estimator.check,
    estimator.Estimator._fuse_mag, estimator.Estimator._fuse_depth, estimator.Estimator._fuse_fix,
    estimator.Estimator._housekeeping, estimator.Estimator._health, estimator.Estimator._outputs,
    attitude.Attitude.predict, attitude.Attitude.heading, attitude.Attitude.normalize,
    attitude.Attitude._rotation, vertical.Vertical.predict, vertical.Vertical.propagate,
    vertical.Vertical.update, horizontal.Horizontal.predict, horizontal.Horizontal.propagate,
    horizontal.Horizontal.update, horizontal.Horizontal._find, horizontal.Horizontal._restart,
    horizontal.Horizontal.set_gain, descent_model.glide_gain, ticks.ticks_diff,
]
def _builds(func) -> list[str]:
    return boardcheck.step_builds(func)


@pytest.mark.parametrize("func", STEP_CODE, ids=lambda f: f.__qualname__)
def test_step_code_builds_no_container_string_or_closure(func):
    assert _builds(func) == []


def test_the_step_code_check_catches_an_allocation():
    def bad(self, x, *rest):
        """Docstring is fine."""
        pairs = [(x, 1)]
        label = "x=%r" % x
        return sorted(pairs), label, lambda: x

    found = " ".join(_builds(bad))
    for what in ("List", "Tuple", "str constant", "sorted()", "Lambda", "*args"):
        assert what in found


def test_package_docstring_documents_the_step_api():
    doc = estimator_pkg.__doc__
    for name in ("imu(t_us", "mag(t_us", "depth(t_us", "fix(t_us", "wings(", "check(t_us"):
        assert name in doc
