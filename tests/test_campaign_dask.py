"""The campaign on a real Dask cluster: a ``dask scheduler`` and two
``dask worker`` processes on 127.0.0.1, started here. The same rows, bit
for bit, as this process gives; a worker killed mid-campaign loses no run.
``pytest -m dask`` selects these."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from roboray.sim import montecarlo as MC
from roboray.sim.campaign import InProcess, read_rows, run
from roboray.sim.campaign.engines import SINGLE_THREAD_ENV

pytestmark = [pytest.mark.dask, pytest.mark.slow]

RUNS, SEED, DEPTH, DISTANCE = 3, 8, 1.0, 0.3
ARGS = ["montecarlo", "--runs", str(RUNS), "--seed", str(SEED), "--depth", str(DEPTH), "--distance", str(DISTANCE)]
SIM = [sys.executable, "-m", "roboray.sim.cli"]
DASK = os.path.join(os.path.dirname(sys.executable), "dask")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    path = tmp_path_factory.mktemp("reference") / "runs.csv"
    out = run(MC.campaign(RUNS, seed=SEED, depth=DEPTH, distance=DISTANCE), InProcess(), results=str(path))
    return path.read_bytes(), out.rows


class Cluster:
    """A scheduler on a free port (``--port 0``, its address from its
    scheduler file) and single-threaded workers, each under its nanny."""

    def __init__(self, folder, workers: int = 2) -> None:
        if not os.path.exists(DASK):
            pytest.skip("no dask command beside %s: pip install 'dask[distributed]'" % sys.executable)
        self.procs: list = []
        env = dict(os.environ, **SINGLE_THREAD_ENV)
        info = os.path.join(str(folder), "scheduler.json")
        self.procs.append(subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", "0",
                                            "--no-dashboard", "--scheduler-file", info],
                                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env))
        end = time.monotonic() + 120
        while not os.path.exists(info) or not os.path.getsize(info):
            assert time.monotonic() < end and self.procs[0].poll() is None, "the dask scheduler did not start"
            time.sleep(0.2)
        time.sleep(0.2)   # the file is written whole, but give it its moment
        with open(info) as f:
            self.address = json.load(f)["address"]
        for _ in range(workers):
            self.procs.append(subprocess.Popen([DASK, "worker", self.address, "--nthreads", "1", "--host",
                                                "127.0.0.1", "--no-dashboard"],
                                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env))
        from distributed import Client

        with Client(self.address, timeout=60) as client:
            client.wait_for_workers(workers, timeout=180)

    def worker_pids(self) -> list[int]:
        from distributed import Client

        with Client(self.address, timeout=60) as client:
            return sorted(client.run(os.getpid).values())

    def close(self) -> None:
        for p in reversed(self.procs):
            if p.poll() is None:
                p.terminate()
        for p in self.procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    c = Cluster(tmp_path_factory.mktemp("dask"))
    try:
        yield c
    finally:
        c.close()


def test_a_dask_cluster_gives_the_rows_of_this_process(tmp_path, cluster, reference):
    path = tmp_path / "runs.csv"
    r = subprocess.run(SIM + ARGS + ["--cluster", cluster.address, "--results", str(path), "--json"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["engine"] == "Dask scheduler %s (2 workers)" % cluster.address and out["runs_run"] == RUNS
    assert path.read_bytes() == reference[0]
    rows = read_rows(str(path))[1]
    assert [r.pop("run") for r in rows] == list(range(RUNS)) and rows == reference[1]


def test_a_killed_dask_worker_loses_no_run(tmp_path, cluster, reference):
    path = tmp_path / "runs.csv"
    proc = subprocess.Popen(SIM + ARGS + ["--cluster", cluster.address, "--results", str(path), "--json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        end = time.monotonic() + 300
        while not path.exists() or path.read_bytes().count(b"\n") < 3:   # a row in
            assert proc.poll() is None, proc.stderr.read()
            assert time.monotonic() < end, "no row after 300 s"
            time.sleep(0.1)
        pids = cluster.worker_pids()
        assert len(pids) == 2
        os.kill(pids[0], signal.SIGKILL)          # its nanny starts another; the scheduler re-runs its task
        out, err = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    rows = read_rows(str(path))[1]
    assert [r.pop("run") for r in rows] == list(range(RUNS)) and rows == reference[1]
    assert path.read_bytes() == reference[0]


def test_a_local_cluster_prints_its_dashboard_and_gives_the_same_rows(tmp_path, reference):
    path = tmp_path / "runs.csv"
    r = subprocess.run(SIM + ARGS + ["--cluster", "local:2", "--results", str(path)], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    assert "Dask LocalCluster of 2 workers, dashboard http://127.0.0.1:" in r.stderr, r.stderr
    assert "Dask LocalCluster of 2 workers: %d runs" % RUNS in r.stdout
    assert path.read_bytes() == reference[0]
