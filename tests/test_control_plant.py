"""The board's copy of the equations of motion (the backstepping
controller's model): generated from the model, and the same numbers."""

from __future__ import annotations

from array import array
from pathlib import Path

import numpy as np
import pytest

from roboray.shared.control.plant import Plant
from roboray.sim.dynamics import Model, quat_to_rot
from roboray.tools import gen_plant


def test_the_committed_tables_are_what_the_generator_writes():
    committed = gen_plant.default_out()
    assert committed.read_text() == gen_plant.generate()
    assert gen_plant.main(["--check"]) == 0


def test_check_reports_a_stale_file(tmp_path: Path, capsys):
    stale = tmp_path / "plant_tables.py"
    stale.write_text("# old\n")
    assert gen_plant.main(["--check", "--out", str(stale)]) == 1
    assert "out of date" in capsys.readouterr().out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_drift_and_reaction_match_the_compiled_model(seed):
    model = Model(None)
    rng = np.random.default_rng(seed)
    s = rng.uniform(0.0, 1.5, 4)
    sd = rng.uniform(-3.0, 3.0, 4)
    V = rng.normal(0.0, 0.3, 3)
    W = rng.normal(0.0, 0.6, 3)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    x = model.state(attitude=q, velocity=V, rates=W, wings=s, wing_rates=sd)
    # nu_dot at zero wing acceleration, from the compiled right-hand side
    dx = model.body_rhs(x, sd[None])
    mvv, mvs = model.inertia(s[None])
    dvv, dvs = model.inertia_rate(s[None], sd[None])
    want = np.linalg.solve(mvv[0], dx[0, 7:13] - dvv[0] @ np.concatenate([V, W]) - dvs[0] @ sd)
    plant = Plant()
    got = array("f", [0.0] * 6)
    f32 = lambda v: array("f", v)  # noqa: E731
    plant.drift(f32(s), f32(sd), f32(V), f32(W), f32(quat_to_rot(q[None])[0, 2]), got)
    assert np.allclose(np.array(got), want, rtol=1e-4, atol=1e-4 * np.abs(want).max())
    B = array("f", [0.0] * 24)
    plant.reaction(B)
    assert np.allclose(np.array(B).reshape(6, 4), -np.linalg.solve(mvv[0], mvs[0]), atol=1e-5)
