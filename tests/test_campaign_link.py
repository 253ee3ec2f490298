"""Campaign flights through the radio link (issue 27): FlightSpec's link,
montecarlo's and sweep's --water/--conductivity/--radio-model."""

from __future__ import annotations

import argparse
import json

import pytest

from roboray.sim import montecarlo as MC
from roboray.sim.cli import main
from roboray.sim.commands.radio import campaign_link
from roboray.sim.flight import FlightSpec, fly


def test_campaign_link_only_when_asked():
    ns = argparse.Namespace
    assert campaign_link(ns(water="fresh", radio_model=None, conductivity=None)) is None
    assert campaign_link(ns(water="sea", radio_model=None, conductivity=None)) == ("sea", "hc12-433", None)
    assert campaign_link(ns(water="fresh", radio_model="sik-915", conductivity=0.05)) == ("fresh", "sik-915", 0.05)


def test_draws_carry_the_link_and_name_it_in_the_campaign():
    plain = MC.draws(3, seed=2)
    linked = MC.draws(3, seed=2, link=("sea", "sik-433", None))
    for a, b in zip(plain, linked):
        assert a.spec.radio_model is None and b.spec.radio_model == "sik-433" and b.spec.water == "sea"
        # the same draws otherwise
        assert a.errors == b.errors and a.spec.target == b.spec.target and a.spec.seed == b.spec.seed
    assert "radio_model" not in MC.campaign(1).params
    assert MC.campaign(1, link=("sea", "sik-433", None)).params["radio_model"] == "sik-433"


def test_flight_spec_refuses_an_unknown_radio_or_water():
    with pytest.raises(ValueError, match="radio_model"):
        FlightSpec(radio_model="wifi")
    with pytest.raises(ValueError, match="water"):
        FlightSpec(water="lake")


def test_a_flight_in_sea_water_loses_its_fixes_below_the_surface():
    free = fly(FlightSpec(seed=5, depth=3.0, target=(0.5, 0.0))).metrics
    sea = fly(FlightSpec(seed=5, depth=3.0, target=(0.5, 0.0), water="sea", radio_model="hc12-433")).metrics
    assert free["fixes_lost_to_link"] == 0
    assert sea["fixes_lost_to_link"] > 0
    assert sea["fixes_used"] + sea["fixes_lost_to_link"] == pytest.approx(free["fixes_used"], abs=3)
    assert sea["landed"] and sea["landing_error_m"] < 0.5


def test_montecarlo_takes_the_link_options(capsys):
    assert main(["montecarlo", "--water", "sea", "--runs", "1", "--workers", "1", "--depth", "2",
                 "--distance", "0.3", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["water"] == "sea" and r["radio_model"] == "hc12-433" and r["landed"] == 1


@pytest.mark.parametrize("cmd", [["montecarlo"], ["sweep", "--param", "wing_height=0.17:0.18"]])
def test_bad_link_options_are_one_line_errors(cmd, capsys):
    with pytest.raises(SystemExit) as e:
        main(cmd + ["--conductivity", "50"])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--conductivity" in err[0]
