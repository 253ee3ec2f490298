"""The radio through water: the physics (sim/radio) and ``roboray-sim radio-reach``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from roboray.sim.cli import main
from roboray.sim.radio import link, radios, water


def test_attenuation_against_a_hand_computed_case():
    # 433 MHz, sigma 1 S/m, 20 C. By hand: eps_s(20) = 87.740 - 8.0016 + 0.37592
    # - 0.01128 = 80.1030; 2 pi tau = 1.1109e-10 - 7.648e-11 + 2.7752e-11 -
    # 4.0768e-12 = 5.82852e-11 s, so omega tau = 433e6 * 5.82852e-11 = 0.0252375;
    # 1 + (omega tau)^2 = 1.000637; eps'' = 75.2030 * 0.0252375 / 1.000637 =
    # 1.896728, eps' = 4.9 + 75.2030 / 1.000637 = 80.05517. sigma_eff = 1 +
    # 2 pi 433e6 eps0 1.896728 = 1.045690 S/m; omega eps = 2.720619e9 *
    # 7.088170e-10 = 1.928439 S/m; ratio 0.5422469; sqrt(1 + r^2) = 1.1375551;
    # alpha = omega sqrt(mu0 eps / 2) sqrt(0.1375551) = 2.720619e9 *
    # 2.110372e-8 * 0.3708842 = 21.2944 Np/m = 184.96 dB/m.
    w = water.WaterRF("test", 1.0, 20.0)
    assert water.static_permittivity(20.0) == pytest.approx(80.1030, abs=1e-3)
    assert water.permittivity(433e6, 20.0).real == pytest.approx(80.0552, abs=1e-3)
    assert -water.permittivity(433e6, 20.0).imag == pytest.approx(1.896728, rel=1e-5)
    assert water.effective_conductivity(433e6, w) == pytest.approx(1.045690, rel=1e-5)
    assert water.attenuation_np(433e6, w) == pytest.approx(21.2944, rel=1e-4)
    assert water.attenuation_db_per_m(433e6, w) == pytest.approx(184.96, rel=1e-4)


def test_good_conductor_and_low_loss_limits():
    # far from both, the general formula meets each textbook limit
    sea = water.WaterRF("s", 50.0, 20.0)        # sigma >> omega eps: skin depth 1/sqrt(pi f mu sigma)
    assert water.skin_depth(433e6, sea) == pytest.approx(1.0 / math.sqrt(math.pi * 433e6 * water.MU0 * 50.0), rel=0.03)
    pure = water.WaterRF("p", 0.0, 20.0)        # sigma << omega eps: alpha = sigma/2 sqrt(mu/eps)
    sig = water.effective_conductivity(433e6, pure)
    eps = water.permittivity(433e6, 20.0).real * water.EPS0
    assert water.attenuation_np(433e6, pure) == pytest.approx(sig / 2.0 * math.sqrt(water.MU0 / eps), rel=1e-3)


def test_distilled_water_still_attenuates_from_its_own_dielectric_loss():
    d = water.WaterRF("distilled", 0.0, 20.0)
    assert 1.0 / (2 * math.pi * water.relaxation_time(20.0)) == pytest.approx(17.1e9, rel=0.02)
    assert 7.0 < water.attenuation_db_per_m(433e6, d) < 10.0


def test_sea_water_at_433_mhz_skin_depth_about_a_centimetre():
    sea = water.WATERS["sea"]
    assert 0.010 < water.skin_depth(433e6, sea) < 0.016
    assert 550.0 < water.attenuation_db_per_m(433e6, sea) < 700.0


def test_fresh_water_within_the_issue_range_and_915_about_four_times_433():
    fresh = water.WATERS["fresh"]
    assert 9.0 < water.attenuation_db_per_m(433e6, fresh) < 17.0
    ratio = water.attenuation_db_per_m(915e6, fresh) / water.attenuation_db_per_m(433e6, fresh)
    assert 3.0 < ratio < 4.5


def test_surface_loss_a_few_db():
    for w in water.WATERS.values():
        for f in (433e6, 915e6):
            assert 3.0 < water.surface_loss_db(f, w) < 8.0


def test_reach_shrinks_with_frequency_and_conductivity():
    r433 = link.make("sik-433", "fresh").reach_m
    r915 = link.make("sik-915", "fresh").reach_m
    assert r915 < r433
    reaches = [link.make("sik-433", "fresh", s).reach_m for s in (0.0, 0.005, 0.05, 0.5, 4.5)]
    assert all(a > b for a, b in zip(reaches, reaches[1:]))
    assert link.make("hc12-433", "sea").reach_m < 0.2 < 2.0 < link.make("hc12-433", "fresh").reach_m


def test_link_budget_adds_up():
    lk = link.make("hc12-433", "fresh")
    r = lk.radio
    assert r.sensitivity_dbm == -100.0      # FU3 at the vehicle's 57,600 baud: 236 kbps air
    lam = link.C / r.freq_hz
    fspl = 20 * math.log10(4 * math.pi * 10.0 / lam)
    assert lk.margin_db(-0.1) == pytest.approx(r.tx_dbm + 2 * r.antenna_dbi - fspl - r.sensitivity_dbm)
    assert lk.margin_db(2.0) == pytest.approx(lk.margin_db(-0.1) - lk.surface_loss_db - 2.0 * lk.attenuation_db_per_m)
    assert lk.margin_db(lk.reach_m) == pytest.approx(0.0, abs=1e-9)
    assert link.frame_loss(lk.margin_db(lk.reach_m)) == pytest.approx(0.5)
    assert link.frame_loss(lk.margin_db(lk.holds_to_m)) == pytest.approx(0.1)


def test_the_buildable_vehicles_radio_is_the_default():
    assert radios.vehicle_radio() == "hc12-433"
    assert radios.radio(None).name == "hc12-433"


def test_channel_loses_frames_as_the_model_says_and_is_deterministic():
    lk = link.make("hc12-433", "fresh")

    def fraction(depth, seed):
        ch = link.Channel(lk, np.random.default_rng(seed))
        n = 0
        for _ in range(20000):
            ch.step(depth, 0.02)
            n += not ch.passes()
        return n / 20000.0

    assert fraction(1.0, 1) == 0.0
    assert fraction(lk.reach_m + 3.0, 1) == 1.0
    at = fraction(lk.reach_m, 1)
    assert 0.35 < at < 0.65          # half lost at the reach (correlated fading: a wide band)
    assert fraction(lk.reach_m, 1) == at


def test_radio_reach_command_json(capsys):
    assert main(["radio-reach", "--radio", "sik-433", "--water", "sea", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert 550 < r["attenuation_db_per_m"] < 700
    assert 0.05 < r["reach_m"] < 0.2
    assert 3 < r["surface_loss_db"] < 8
    losses = [row["frame_loss"] for row in r["rows"]]
    assert losses == sorted(losses) and losses[0] < 0.01 and losses[-1] > 0.99


def test_radio_reach_conductivity_and_distance_options(capsys, tmp_path):
    assert main(["radio-reach", "--water", "fresh", "--json"]) == 0
    base = json.loads(capsys.readouterr().out)
    assert base["radio"] == "hc12-433"
    assert main(["radio-reach", "--water", "fresh", "--conductivity", "0.05", "--ground-distance", "100",
                 "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["conductivity_s_per_m"] == 0.05
    assert r["attenuation_db_per_m"] > base["attenuation_db_per_m"]
    assert r["reach_m"] < base["reach_m"]
    png = tmp_path / "reach.png"
    assert main(["radio-reach", "--radio", "sik-915", "--plot", str(png)]) == 0
    assert "reach_m" in capsys.readouterr().out
    assert png.stat().st_size > 1000


@pytest.mark.parametrize("argv", [["--conductivity", "-1"], ["--conductivity", "x"], ["--radio", "wifi"],
                                  ["--ground-distance", "0.1"], ["--water", "lake"]])
def test_radio_reach_bad_input_one_line_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as e:
        main(["radio-reach"] + argv)
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0]
