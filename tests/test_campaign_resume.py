"""Real landings, a real command killed: ``montecarlo --results`` killed
with SIGKILL once its file has rows continues to the rows of an
uninterrupted run, every run once; a local worker process killed
mid-campaign loses no run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import psutil
import pytest

from roboray.sim import montecarlo as MC
from roboray.sim.campaign import InProcess, read_rows, run

#: Few, short landings: 1 m to the bottom, targets 0.3 m away.
RUNS, SEED, DEPTH, DISTANCE = 3, 5, 1.0, 0.3
ARGS = ["montecarlo", "--runs", str(RUNS), "--seed", str(SEED), "--depth", str(DEPTH), "--distance", str(DISTANCE)]
SIM = [sys.executable, "-m", "roboray.sim.cli"]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted campaign on this process: its file's bytes and rows."""
    path = tmp_path_factory.mktemp("reference") / "runs.csv"
    out = run(MC.campaign(RUNS, seed=SEED, depth=DEPTH, distance=DISTANCE), InProcess(), results=str(path))
    assert len(out.rows) == RUNS and all(r["landed"] for r in out.rows)
    return path.read_bytes(), out.rows


def rows_in(path) -> int:
    """Complete rows in a results file being written."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except FileNotFoundError:
        return 0
    return max(0, data.count(b"\n") - 2)


def start(argv, **kw) -> subprocess.Popen:
    # its own session: the test can end the command and its workers as a power cut would
    return subprocess.Popen(SIM + argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, **kw)


def wait_for_rows(proc, path, n: int, limit_s: float = 300.0) -> None:
    end = time.monotonic() + limit_s
    while rows_in(path) < n:
        if proc.poll() is not None:
            raise AssertionError("the command ended before %d rows: %s" % (n, proc.stderr.read()))
        assert time.monotonic() < end, "no %d rows in %s after %g s" % (n, path, limit_s)
        time.sleep(0.1)


def kill_group(proc) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


@pytest.mark.slow
def test_killed_with_sigkill_it_resumes_to_the_uninterrupted_rows(tmp_path, reference):
    path = tmp_path / "runs.csv"
    argv = ARGS + ["--workers", "2", "--results", str(path)]
    proc = start(argv)
    try:
        wait_for_rows(proc, path, 1)
        os.kill(proc.pid, signal.SIGKILL)        # the command, mid-campaign
    finally:
        kill_group(proc)                         # and what it left running
    present = rows_in(path)
    assert 1 <= present < RUNS
    # the power cut came in the middle of writing the next row
    with open(path, "a") as f:
        f.write("%d,%d,12.5" % (RUNS - 1, SEED * 100000 + RUNS - 1))
    done = subprocess.run(SIM + argv + ["--json"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "%d of %d runs already there" % (present, RUNS) in done.stderr
    assert "last line was cut short" in done.stderr and "redone" in done.stderr
    assert path.read_bytes() == reference[0]
    head, rows = read_rows(str(path))
    assert [r.pop("run") for r in rows] == list(range(RUNS))      # every run once
    assert rows == reference[1]
    assert head["params"]["runs"] == RUNS and head["kind"] == "montecarlo"
    assert (tmp_path / "runs.summary.json").exists()


@pytest.mark.slow
def test_a_killed_local_worker_loses_no_run(tmp_path, reference):
    path = tmp_path / "runs.csv"
    proc = start(ARGS + ["--workers", "2", "--results", str(path), "--json"])
    try:
        wait_for_rows(proc, path, 1)
        workers = [p for p in psutil.Process(proc.pid).children(recursive=True)
                   if "spawn_main" in " ".join(p.cmdline())]
        assert len(workers) == 2, [p.cmdline() for p in workers]
        workers[0].send_signal(signal.SIGKILL)
        out, err = proc.communicate(timeout=600)
    finally:
        kill_group(proc)
    assert proc.returncode == 0, err
    assert "a worker process died" in err and "resubmitted to a new pool" in err
    head, rows = read_rows(str(path))
    assert [r.pop("run") for r in rows] == list(range(RUNS))
    assert rows == reference[1] and path.read_bytes() == reference[0]


@pytest.mark.slow
def test_ctrl_c_stops_the_workers_and_says_how_to_continue(tmp_path, reference):
    path = tmp_path / "runs.csv"
    proc = start(ARGS + ["--workers", "2", "--results", str(path)])
    try:
        wait_for_rows(proc, path, 1)
        workers = psutil.Process(proc.pid).children(recursive=True)
        os.killpg(proc.pid, signal.SIGINT)       # Ctrl-C reaches the whole foreground group
        out, err = proc.communicate(timeout=120)
    finally:
        kill_group(proc)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "interrupted with" in err and "the same command continues" in err, err
    psutil.wait_procs(workers, timeout=10)
    assert not [w for w in workers if w.is_running() and w.status() != psutil.STATUS_ZOMBIE]
    present = rows_in(path)
    assert 1 <= present < RUNS
    # mid-campaign, in the order the runs ended: each row as the uninterrupted run wrote it
    lines = path.read_bytes().split(b"\n")
    assert lines[:2] == reference[0].split(b"\n")[:2]
    assert set(lines[2:2 + present]) <= set(reference[0].split(b"\n")[2:])


def exit_of(capsys, argv) -> tuple[int, str]:
    """The command's exit status and its stderr, run here."""
    from roboray.sim import cli

    try:
        status = cli.main(argv)
    except SystemExit as exc:   # argparse's own errors
        status = exc.code
    return status, capsys.readouterr().err


def test_engine_options_that_contradict_are_usage_errors(tmp_path, capsys):
    for argv, message in (
            (["--workers", "2", "--cluster", "local:2"], "a --cluster brings its own workers"),
            (["--cluster", "udp://x:1"], "give tcp://HOST:PORT"),
            (["--cluster", "local:0"], "local:N needs a whole number"),
            (["--results", str(tmp_path / "r.txt")], "ends in .csv or .parquet")):
        status, err = exit_of(capsys, ARGS + argv)
        assert status == 2 and message in err and "Traceback" not in err, err
        assert len(err.strip().splitlines()) == 1


def test_no_scheduler_and_another_campaigns_file_are_one_line(tmp_path, capsys):
    with socket_closed() as port:
        status, err = exit_of(capsys, ARGS + ["--cluster", "tcp://127.0.0.1:%d" % port])
    assert status == 1 and "no Dask scheduler answers at tcp://127.0.0.1:%d" % port in err, err
    assert len(err.strip().splitlines()) == 1
    other = tmp_path / "runs.csv"
    run(MC.campaign(1, seed=SEED + 1, depth=DEPTH, distance=DISTANCE), InProcess(), results=str(other))
    before = other.read_bytes()
    status, err = exit_of(capsys, ARGS + ["--workers", "1", "--results", str(other)])
    assert status == 1 and "holds another montecarlo campaign" in err, err
    assert len(err.strip().splitlines()) == 1 and other.read_bytes() == before


class socket_closed:
    """A port on 127.0.0.1 nothing listens on."""

    def __enter__(self) -> int:
        import socket

        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        s.close()
        return port

    def __exit__(self, *exc) -> None:
        pass
