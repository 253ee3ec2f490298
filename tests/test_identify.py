"""roboray-sim identify on the twin's logs: a perturbed buildable vehicle
flown by the firmware (sensor noise and biases on), its log identified
from the unperturbed vehicle file (docs/design/identification.md)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from roboray.ground import paramfile
from roboray.shared import param_defs
from roboray.shared.estimator import descent_model
from roboray.sim.cli import main
from roboray.sim.identify import parameters as PM
from roboray.sim.vehicle import load_params
from roboray.tools import boardcheck

BUILDABLE = "sim/vehicles/buildable.py"
PERTURBED = "tests/data/identify/perturbed_buildable.py"
NO_MUNK = "tests/data/identify/perturbed_buildable_no_munk.py"


def _dive(folder, vehicle):
    """A 4 m target landing of ``vehicle`` in the twin; its log's path."""
    from roboray.sim.twin.runner import Options, Twin

    Twin(Options(scenario="target-landing", seed=1, interpreter="cpython", depth=4.0, target=(1.2, 0.6),
                 vehicle=vehicle, board_fs=str(folder))).run()
    path = folder / "logs" / "00000001.BIN"
    assert path.is_file()
    return str(path)


def _identify(capsys, *argv):
    assert main(["identify", *argv, "--json"]) in (0, None)
    return json.loads(capsys.readouterr().out)


@pytest.fixture(scope="module")
def perturbed(tmp_path_factory):
    folder = tmp_path_factory.mktemp("identify")
    return folder, _dive(folder / "fs", PERTURBED)


@pytest.fixture(scope="module")
def identified(perturbed):
    folder, log = perturbed
    out, parm = folder / "fitted.py", folder / "fitted.parm"
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["identify", log, "--vehicle", BUILDABLE, "--out", str(out), "--params-out", str(parm),
                     "--json"]) in (0, None)
    return json.loads(buf.getvalue()), out, parm


def test_drag_within_10_percent_and_every_reported_parameter_within_3_sigma(identified):
    result, _, _ = identified
    truth = PM.values(load_params(PERTURBED), load_params(BUILDABLE))
    params = result["params"]
    assert params["cd"]["identifiable"]
    assert abs(params["cd"]["value"] / truth["cd"] - 1.0) <= 0.10
    reported = [n for n, p in params.items() if p["identifiable"]]
    assert len(reported) >= 3
    for n in reported:
        p = params[n]
        assert abs(p["value"] - truth[n]) <= 3.0 * p["sigma"], (n, p, truth[n])
    for n in result["unidentifiable"]:
        assert params[n]["value"] is None and params[n]["sigma"] > 0
    after, before = result["fit_rms_after"], result["fit_rms_before"]
    assert after["depth"] < before["depth"] and after["tilt"] < before["tilt"]


def test_fitted_vehicle_and_parameter_files_are_written_and_load(identified):
    result, out, parm = identified
    fitted = load_params(str(out))
    assert "roboray-sim identify" in out.read_text()
    assert fitted.cd == pytest.approx(result["params"]["cd"]["value"])
    values = paramfile.load(str(parm))
    decl = {d[0]: d for d in param_defs.DESCENT}
    assert set(values) == set(descent_model.PARAM_NAMES)
    for name, value in values.items():
        assert decl[name][3] <= value <= decl[name][4]
    model = descent_model.DescentModel((values["DR_GLIDE_K0"], values["DR_GLIDE_K45"], values["DR_GLIDE_K90"]),
                                       values["DR_DIFF_K"], values["DR_TAU"])
    assert model.glide_gain(45.0) == pytest.approx(values["DR_GLIDE_K45"])


def test_the_munk_switch_is_recovered_from_logs_flown_with_and_without_it(perturbed, capsys, tmp_path):
    _, with_munk = perturbed
    without = _dive(tmp_path / "fs", NO_MUNK)
    seen = []
    for log, truth in ((with_munk, 1.0), (without, 0.0)):
        r = _identify(capsys, log, "--vehicle", BUILDABLE, "--fit", "cd,added_mass_wing,added_mass_center,munk_scale")
        p = r["params"]["munk_scale"]
        assert p["identifiable"]
        assert abs(p["value"] - truth) <= 3.0 * p["sigma"]
        seen.append(p)
    assert seen[0]["value"] - seen[1]["value"] > 3.0 * (seen[0]["sigma"] + seen[1]["sigma"])


@pytest.mark.parametrize("content", [None, b"hello, not a log\n", b"\xa3\x95\x80" + bytes(40)])
def test_bad_log_is_one_line_and_exit_2(tmp_path, capsys, content):
    path = tmp_path / "dive.BIN"
    if content is not None:
        path.write_bytes(content)
    assert main(["identify", str(path), "--vehicle", BUILDABLE]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "dive.BIN" in err[0]


def test_descent_model_reads_its_parameters_and_steps_without_building_anything():
    from roboray.shared.params import ParamTable

    table = ParamTable(param_defs.PARAMS)
    table.set(table.index("DR_DIFF_K"), 0.5)
    model = descent_model.from_params(table)
    out = [0.0, 0.0]
    model.glide_vector(np.pi / 2, 0.0, 0.0, 0.0, out)
    assert out[0] == pytest.approx(0.5) and out[1] == 0.0
    assert model.glide_gain(0.0) == pytest.approx(param_defs.DESCENT[0][2])
    defaults = {d[0]: d[2] for d in param_defs.DESCENT}
    assert [defaults[n] for n in descent_model.PARAM_NAMES] == pytest.approx(
        list(descent_model.GLIDE_GAIN) + [descent_model.DIFF_GAIN, descent_model.TAU_S])
    for f in (descent_model.DescentModel.glide_vector, descent_model.DescentModel.glide_gain):
        assert boardcheck.step_builds(f) == []
