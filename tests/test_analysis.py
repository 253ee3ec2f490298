"""Analyses: the thesis's tables, trims, modes, glide envelope, controllability."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from roboray.sim.analysis import controllability, envelope, reduced, trim
from roboray.sim.dynamics import Model
from roboray.sim.simulate import simulate
from roboray.sim.vehicle import Vehicle, load_params


@pytest.fixture(scope="module")
def vehicle():
    return Vehicle()


@pytest.fixture(scope="module")
def model():
    return Model(None)


# ------------------------------------------------------------ Table 3.1/3.2
def test_table_3_1_impossible_rows_are_flagged(vehicle):
    rows = {r["row"]: r for r in reduced.table(vehicle, "3.1")}
    for k, g2 in ((3, -6.9), (4, -13.8), (6, -1.27)):
        assert rows[k]["exists"] is False
        assert rows[k]["gamma2"] == pytest.approx(g2, rel=0.01)
        assert not rows[k]["agrees_with_thesis"]
        assert "|Gamma_2| <= 1" in rows[k]["note"] and "%.3g" % rows[k]["gamma2"] in rows[k]["note"]
    assert rows[5]["exists"] and rows[5]["gamma2"] == pytest.approx(-0.635, abs=0.002)
    for k in (1, 2, 5):   # every other verdict agrees: these equilibria are spectrally stable
        assert rows[k]["agrees_with_thesis"] and rows[k]["spectrally_stable"], k
        assert rows[k]["energy_casimir"]


def test_table_3_2_agrees(vehicle):
    rows = reduced.table(vehicle, "3.2")
    assert len(rows) == 9
    assert all(r["exists"] and r["spectrally_stable"] and r["agrees_with_thesis"] for r in rows)


def test_reduced_jacobian_matches_finite_differences(vehicle):
    red = reduced.ReducedModel.of(vehicle, np.radians([10, 80, 30, 60]))
    y = np.concatenate([red.impulses(np.array([0.05, -0.1, 0.4]), np.array([0.2, -0.1, 0.3])),
                        [0.1, -0.2, np.sqrt(0.95)]])
    fd = trim.jacobian(red.field, y)
    assert np.allclose(red.jacobian(y), fd, atol=1e-7, rtol=1e-6)


@pytest.mark.parametrize("s13, s24", [(0, 0), (45, 45), (0, 90), (90, 90), (70, 20), (90, 60)])
def test_straight_fall_tilt_modes_match_the_closed_form(vehicle, s13, s24):
    """The numeric verdict of the reduced model equals the closed form of
    ``straight_fall_tilt_condition`` over descent speeds on both sides of the
    Munk threshold, for a bottom-heavy and a bottom-light vehicle."""
    light = Vehicle(replace(load_params(), payload_height=0.040))     # CG above the CB: ell < 0
    assert light.ell(np.zeros(4)) < 0
    verdicts = set()
    for v in (vehicle, light):
        red = reduced.ReducedModel.of(v, np.radians([s13, s24, s13, s24]))
        for v3 in (0.05, 0.3, 0.6, 1.0, 2.0, 4.0):
            pitch, roll = reduced.straight_fall_tilt_condition(red, v3)
            numeric = reduced.spectrum(red.jacobian(red.no_spin_state(0.0, v3)))["spectrally_stable"]
            assert numeric == (pitch and roll), (v.ell(np.zeros(4)), s13, s24, v3)
            verdicts.add(numeric)
    assert verdicts == {True, False}   # both outcomes occur, so the check can fail


# ------------------------------------------------------------ trims, modes
@pytest.mark.parametrize("wings_deg", [(0, 0, 0, 0), (0, 45, 90, 45), (0, 0, 90, 90)])
def test_trim_is_an_equilibrium_and_a_simulation_stays_there(model, wings_deg):
    t = trim.find_trims(model, np.radians(wings_deg), settle_s=30.0)[0]
    assert t.residual < trim.TRIM_TOL
    run = simulate(model, t.state(model), 20.0, dt=0.01)
    assert np.abs(run.nu[:, 0] - run.nu[0, 0]).max() < 1e-6
    if wings_deg != (0, 0, 0, 0):
        assert t.straight and t.glide_ratio > 0.2    # folding one side makes it glide


def test_mode_eigenvalues_match_the_full_model(model):
    """The 9-coordinate linearisation of ``modes`` against a finite-difference
    Jacobian of the full 17-state model (position, quaternion, momenta, servos)."""
    t = trim.find_trims(model, np.radians([0, 45, 90, 45]), settle_s=30.0)[0]
    ours = np.array([complex(*m["eigenvalue"]) for m in trim.modes(model, t)["modes"]])
    x0 = t.state(model)[0]
    cmd = t.wings[None, :]
    full = np.linalg.eigvals(trim.jacobian(lambda x: model.rhs(x[None, :], cmd)[0], x0))
    servo = -1.0 / model.vehicles[0].p.servo_tau
    rest = [e for e in full if abs(e) > 1e-4 and abs(e - servo) > 1e-3]
    assert len(rest) == len(ours) == 8
    for e in ours:
        assert min(abs(e - f) for f in rest) < 1e-4 * max(1.0, abs(e))


def test_all_wings_up_straight_fall_is_unstable_but_a_tilted_glide_is_not(model):
    trims = trim.find_trims(model, np.radians([90, 90, 90, 90]), settle_s=30.0)
    straight_down = [t for t in trims if t.tilt_deg < 1e-3]
    tilted = [t for t in trims if t.tilt_deg > 10 and trim.modes(model, t)["stable"]]
    assert straight_down and not trim.modes(model, straight_down[0])["stable"]
    assert tilted   # the drop settles into a tilted glide instead


# ------------------------------------------------------------ controllability
def test_controllability_rank_drops_where_inputs_cannot_act(model):
    """Flat wings, straight fall: no wing can make a moment about z_c (every
    drag force lies in its wing's radial plane), so heading and spin are out
    of reach; folding two adjacent wings breaks that and restores full rank."""
    flat = trim.find_trims(model, np.zeros(4), settle_s=20.0)[0]
    lin = controllability.linear(model, flat)
    assert lin["rank"] == lin["state_dimension"] - 2
    assert set(lin["uncontrollable_states"]) == {"theta_z", "pi_z"}
    glide = trim.find_trims(model, np.radians([0, 0, 90, 90]), settle_s=20.0)[0]
    full = controllability.linear(model, glide)
    assert full["rank"] == full["state_dimension"] == 16
    lie = controllability.lie_rank(model, glide, depth=3)
    assert lie["rank"] == lie["state_dimension"] == 20


# ------------------------------------------------------------ envelope
def test_envelope_finds_a_stable_glide_on_a_coarse_grid():
    result = envelope.search(step_deg=45.0, settle_s=25.0, refine=False)
    assert result["stable"] and result["max_glide_ratio"] > 0.3
    assert result["wings_deg"] is not None and result["descent_speed"] > 0.3
    # at least as good as any single configuration the search tried
    assert all(envelope.glide_score(c if c["trim"] else None) <= result["max_glide_ratio"] + 1e-12
               for c in result["candidates"])


# ------------------------------------------------------------ commands
def sim(*args):
    return subprocess.run([sys.executable, "-m", "roboray.sim.cli", *args], capture_output=True, text=True,
                          timeout=600)


def test_stability_table_json_has_the_row_keys():
    out = json.loads(sim("stability", "--table", "3.1", "--json").stdout)
    assert len(out["rows"]) == 6
    for key in ("s1", "s2", "v2", "v3", "m1", "m2", "m3", "ell", "exists", "spectrally_stable", "max_real_eig",
                "energy_casimir", "agrees_with_thesis"):
        assert key in out["rows"][0], key
    assert "note" in out["rows"][2] and "note" not in out["rows"][0]


def test_stability_any_equilibrium_and_bad_combination():
    out = json.loads(sim("stability", "--wings", "0,0,0,0", "--v3", "0.5", "--omega3", "1", "--json").stdout)
    assert out["rows"][0]["exists"] and out["rows"][0]["spectrally_stable"]
    proc = sim("stability", "--wings", "0,0,0,0", "--v2", "1", "--omega3", "1")
    assert proc.returncode == 2 and "v2 = 0" in proc.stderr


def test_trim_modes_and_map_commands(tmp_path):
    out = json.loads(sim("trim", "--wings", "0,45,90,45", "--json").stdout)
    assert out["trims"][0]["glide_ratio"] > 0.2 and out["trims"][0]["stable"]
    modes = json.loads(sim("modes", "--wings", "0,0,0,0", "--json").stdout)
    names = {m["mode"] for m in modes["modes"]}
    assert {"heave", "spin"} <= names and modes["stable"]
    png = tmp_path / "map.png"
    res = json.loads(sim("stability-map", "--out", str(png), "--step", "45", "--settle", "20", "--json").stdout)
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert set(res["slices"]) == {"s13_vs_s24", "s1_vs_s3_at_s24_45"}
