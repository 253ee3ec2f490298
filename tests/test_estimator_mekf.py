"""The multiplicative EKF kept for comparison: it runs in the estimator,
aligns, and gives the same answers on MicroPython."""

from __future__ import annotations

import json
import math

import numpy as np

from roboray.sim import estimation as E
from roboray.sim.sensors import trajectory
from roboray.tools.micropython import assert_close_f32

ATTITUDE = trajectory.euler_to_quaternion(np.array(-0.15), np.array(0.1), np.array(2.0))


def _prepared(seconds):
    truth = trajectory.still(seconds, quaternion=ATTITUDE)
    p = E.prepare(truth, 11)
    return truth, dict(p.config, attitude_filter="mekf"), p


def test_mekf_aligns_in_the_estimator():
    truth, config, p = _prepared(10.0)
    est = E.run(config, p.calls, p.t)
    q = est.q[-1]
    err = math.degrees(2.0 * math.acos(min(1.0, abs(float(np.dot(q, truth.quaternion[0])) / np.linalg.norm(q)))))
    assert err < 1.5
    assert est.status[-1, 1] == 1


def test_mekf_gives_the_same_answers_on_micropython(micropython):
    truth, config, p = _prepared(3.0)
    on_cpython = E.run(config, p.calls, p.t, every=10)
    micropython.write_file("/tmp/mekf_cfg.json", json.dumps(config))
    micropython.write_file("/tmp/mekf_log.json", json.dumps(p.calls))
    micropython.exec(E.REPLAY)
    snaps = micropython.eval("replay(build(__import__('json').load(open('/tmp/mekf_cfg.json'))), "
                             "__import__('json').load(open('/tmp/mekf_log.json')), 10)")
    on_micropython = E.Estimates.from_snapshots(on_cpython.t, snaps)
    assert_close_f32(on_cpython.q.tolist(), on_micropython.q.tolist())
    assert_close_f32(on_cpython.nav.tolist(), on_micropython.nav.tolist())
