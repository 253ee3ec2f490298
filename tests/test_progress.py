"""Progress with an ETA on a terminal (sim/progress.py): drawn on a
pseudo-terminal, never on a pipe or with --json, and updated per finished
unit where the work runs in worker processes."""

import argparse
import json
import os
import pty
import re
import subprocess
import sys

import pytest

from roboray.sim import progress

SIM = [sys.executable, "-m", "roboray.sim.cli"]


def on_terminal(args, timeout=600):
    """Run with stderr on a fresh pseudo-terminal (0 x 0, as openpty makes
    it); stdout on a pipe. Returns (exit status, stdout, what the terminal got)."""
    master, slave = pty.openpty()
    proc = subprocess.Popen(SIM + args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=slave)
    os.close(slave)
    seen = b""
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:   # the other end closed
            break
        if not chunk:
            break
        seen += chunk
    os.close(master)
    out = proc.stdout.read().decode()
    proc.wait(timeout=timeout)
    return proc.returncode, out, seen.decode("utf-8", "replace")


def bar_states(terminal: str, name: str) -> list:
    """Every state of the bar ``name`` drawn, in order."""
    return [f.strip() for f in terminal.split("\r") if f.strip().startswith(name + ":")]


def test_shown_only_on_a_terminal_and_without_json(tmp_path):
    assert progress.shown(argparse.Namespace(json=True)) is False
    with open(tmp_path / "err", "w") as fh:
        old = sys.stderr
        sys.stderr = fh
        try:
            assert progress.shown(argparse.Namespace(json=False)) is False
            with progress.bar(argparse.Namespace(json=False), 3, "x") as b:
                assert b is progress.QUIET
                b.update(1)
                b.set_postfix_str("nothing")
        finally:
            sys.stderr = old
    assert (tmp_path / "err").read_text() == ""


def test_stability_map_draws_a_bar_with_an_eta_on_a_terminal(tmp_path):
    png = tmp_path / "map.png"
    status, out, terminal = on_terminal(["stability-map", "--out", str(png), "--step", "45", "--settle", "5"])
    assert status == 0, terminal
    states = bar_states(terminal, "stability-map")
    assert len(states) >= 5, terminal
    percents = [int(re.search(r"(\d+)%", s).group(1)) for s in states]
    assert percents == sorted(percents) and percents[-1] > 50, states
    assert any(re.search(r"\d\d:\d\d<\d\d:\d\d", s) for s in states), states   # elapsed<remaining
    assert "slice 1 of 2" in terminal and "slice 2 of 2" in terminal
    assert "wrote %s" % png in out and "%|" not in out   # the report on stdout is untouched


class Tally:
    """What an analysis reports to its bar."""

    def __init__(self):
        self.total = 0.0
        self.stages = []

    def update(self, n=1):
        self.total += n

    def set_postfix_str(self, text="", refresh=True):
        self.stages.append(text)


def test_the_analyses_report_exactly_the_work_they_announce():
    from roboray.sim.analysis import envelope, stability_map

    tally = Tally()
    stability_map.compute(step_deg=45.0, settle_s=5.0, progress=tally)
    assert tally.total == pytest.approx(stability_map.compute_cost(45.0, 5.0), rel=1e-9)
    assert tally.stages == ["slice 1 of 2", "slice 2 of 2"]
    for refine in (False, True):
        tally = Tally()
        envelope.search(step_deg=90.0, settle_s=5.0, refine=refine, progress=tally)
        assert tally.total == pytest.approx(envelope.search_cost(90.0, 5.0, refine), rel=1e-9)
        assert tally.stages[-1] == "asymmetric checks" and ("refining" in tally.stages) == refine


def test_no_bar_on_a_pipe_nor_with_json(tmp_path):
    r = subprocess.run(SIM + ["stability-map", "--out", str(tmp_path / "a.png"), "--step", "45", "--settle", "5"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "stability-map:" not in r.stderr and "\r" not in r.stderr and "%|" not in r.stderr
    status, out, terminal = on_terminal(["stability-map", "--out", str(tmp_path / "b.png"), "--step", "45",
                                         "--settle", "5", "--json"])
    assert status == 0, terminal
    assert bar_states(terminal, "stability-map") == [] and "%|" not in terminal, terminal
    assert json.loads(out)["plot"] == str(tmp_path / "b.png")


def test_counted_runs_one_by_one():
    status, out, terminal = on_terminal(["thesis-control", "--duration", "2", "--kv2", "1,10"])
    assert status == 0, terminal
    counts = [s.split("|")[0] for s in bar_states(terminal, "thesis-control")]
    for k in range(6):
        assert "thesis-control: %d/5 runs" % k in counts, counts
    assert "sec. 5.2.1" in out


def test_montecarlo_counts_each_flight_as_its_worker_finishes(tmp_path):
    runs = tmp_path / "runs.csv"
    status, out, terminal = on_terminal(["montecarlo", "--runs", "2", "--workers", "2", "--results", str(runs)])
    assert status == 0, terminal
    counts = [s.split("|")[0] for s in bar_states(terminal, "montecarlo")]
    assert counts[0] == "montecarlo: 0/2 flights" and "montecarlo: 1/2 flights" in counts, counts
    assert counts[-1] == "montecarlo: 2/2 flights", counts
    assert "2 target landings" in out
    assert len(runs.read_text().splitlines()) == 4   # the campaign's line, the column names, two runs


@pytest.mark.parametrize("argv", [
    ["envelope", "--step", "90", "--settle", "5", "--no-refine"],
    ["bench", "dynamics", "--duration", "2", "--batch", "10", "--batch-duration", "1"],
    ["bench", "mavlink", "--frames", "200", "--fuzz", "500", "--repeat", "1", "--no-micropython"],
    ["fly", "--mode", "velocity", "--truth", "--max-time", "4"],
])
def test_every_long_job_draws_its_bar(argv):
    name = argv[0] if argv[0] != "bench" else "bench " + argv[1]
    status, out, terminal = on_terminal(argv)
    assert status == 0, terminal
    states = bar_states(terminal, name)
    assert states and re.search(r"\d+%", states[-1]), terminal
    assert out.strip()
