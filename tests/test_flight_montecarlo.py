"""Monte Carlo landings (sim/montecarlo.py): the draws, one landing as a row, the summary."""

from __future__ import annotations

import dataclasses
import json
import math
import pickle

import numpy as np
import pytest

from roboray.sim import flight as F
from roboray.sim import montecarlo as MC
from roboray.sim.campaign import InProcess, run
from roboray.sim.vehicle import Vehicle, load_params


def test_plan_draws_every_model_error_within_ten_percent():
    specs = MC.plan(40, seed=3)
    base = load_params()
    ell0 = Vehicle(base).ell(np.zeros(4))
    seen = {"added": [], "cd": [], "ell": [], "tau": []}
    for s in specs:
        v = dict(s.vehicle)
        factors = [v[name] / getattr(base, name) for name in MC.ADDED_MASS_FIELDS]
        assert max(factors) - min(factors) < 1e-12   # one draw scales every added-mass coefficient
        seen["added"].append(factors[0])
        seen["cd"].append(v["cd"] / base.cd)
        seen["tau"].append(v["servo_tau"] / base.servo_tau)
        seen["ell"].append(Vehicle(dataclasses.replace(base, payload_height=v["payload_height"])).ell(np.zeros(4)) / ell0)
        assert math.hypot(*s.target) == pytest.approx(2.0)
        assert 0.01 <= s.tracker_noise_m <= 0.04
    for name, f in seen.items():
        f = np.array(f)
        assert np.all(np.abs(f - 1.0) <= 0.1 + 1e-9), name
        assert f.max() - f.min() > 0.1, name   # really spread
    assert len({s.seed for s in specs}) == len(specs)
    assert MC.plan(40, seed=3) == specs     # reproducible
    assert MC.plan(10, seed=3) == specs[:10]   # a run depends on its index alone


def test_a_spec_is_plain_data_for_another_engine():
    spec = MC.plan(1, seed=1)[0]
    assert pickle.loads(pickle.dumps(spec)) == spec
    as_json = json.loads(json.dumps(spec.as_dict()))
    rebuilt = F.FlightSpec(**{k: tuple(tuple(x) if isinstance(x, list) else x for x in v) if isinstance(v, list)
                              else v for k, v in as_json.items()})
    assert rebuilt == spec


def test_specs_under_model_errors_land_close_in_order():
    # one process here (a pool's workers each import the model anew, seconds
    # a test need not spend; the 100-run command uses the pool)
    campaign = MC.campaign(2, seed=9, depth=4.0, distance=0.8)
    rows = run(campaign, InProcess()).rows
    assert [r["seed"] for r in rows] == [900000, 900001]
    for r, draw in zip(rows, campaign.tasks):
        assert r["landed"] and r["landing_error_m"] < 0.5
        assert (r["target_north_m"], r["target_east_m"]) == draw.spec.target
        assert tuple(r[name] for name in MC.ERRORS) == draw.errors
        assert set(r) == {name for name, _ in MC.COLUMNS}
    json.dumps(rows)


def test_summary_percentiles():
    results = [{"landing_error_m": e, "max_tilt_deg": 5.0, "seed": i} for i, e in
               enumerate(np.linspace(0.0, 1.0, 101))]
    s = MC.summary(results)
    assert s["landing_error_p50_m"] == pytest.approx(0.5)
    assert s["landing_error_p95_m"] == pytest.approx(0.95)
    assert s["landing_error_worst_m"] == 1.0 and s["worst_run"] == {"landing_error_m": 1.0, "max_tilt_deg": 5.0,
                                                                    "seed": 100, "run": 100}
    results.append({"landing_error_m": None, "max_tilt_deg": 5.0, "seed": 101})
    s = MC.summary(results)
    assert s["landed"] == 101 and s["runs"] == 102 and s["landing_error_worst_m"] is None


def test_flight_spec_rejects_bad_input():
    with pytest.raises(ValueError, match="controller"):
        F.FlightSpec(controller="pid")
    with pytest.raises(ValueError, match="depth"):
        F.FlightSpec(depth=0.2)
    with pytest.raises(ValueError, match="dt"):
        F.FlightSpec(dt=0.003)
    with pytest.raises(ValueError, match="refused"):
        F.make_controller(F.FlightSpec(ctl=(("CTL_TGT_K", 99.0),)))
