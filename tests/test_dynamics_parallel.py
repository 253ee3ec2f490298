"""The batched dynamics on numba's threads: the same numbers, bit for bit,
whatever the thread count, as the serial step and as one vehicle alone."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace

import numba
import numpy as np
import pytest

from roboray.sim import kernels
from roboray.sim.dynamics import Bottom, Current, Model, quat_from_axis_angle
from roboray.sim.simulate import simulate
from roboray.sim.vehicle import load_params

OUTPUTS = ("x", "nu", "wing_rates", "specific_force_imu", "depth_sensor", "landed_at")
two_threads = pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2,
                                 reason="numba has one thread here (one core, or NUMBA_NUM_THREADS=1)")


@pytest.fixture(autouse=True)
def restore_threads():
    before = numba.get_num_threads()
    yield
    numba.set_num_threads(before)


def fleet_model(**options) -> Model:
    """Seven different vehicles: seven does not divide among two threads."""
    p = load_params()
    return Model([p, replace(p, cd=1.1), replace(p, cf=0.01), replace(p, servo_tau=0.08),
                  replace(p, payload_height=0.012), replace(p, cd=1.4, servo_rate=3.0), p], **options)


def scattered(model: Model, seed: int = 3):
    """Start states and commands that differ from vehicle to vehicle."""
    rng = np.random.default_rng(seed)
    n = model.n
    axes = rng.normal(size=(n, 3))
    q = np.array([quat_from_axis_angle(a, t) for a, t in zip(axes, rng.uniform(0, 0.5, n))])
    x0 = model.state(attitude=q, velocity=rng.normal(0, 0.1, (n, 3)) + [0, 0, 0.3],
                     rates=rng.normal(0, 0.2, (n, 3)), wings=rng.uniform(0, 1.5, (n, 4)))
    return x0, rng.uniform(-0.1, 1.7, (n, 4))


def run_on(threads: int, model: Model, x0, cmd, **kw):
    numba.set_num_threads(threads)
    return simulate(model, x0, 3.0, dt=0.01, command=cmd, **kw)


def assert_same(a, b):
    for name in OUTPUTS:
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name


@two_threads
@pytest.mark.parametrize("options", [{}, {"current": Current(velocity=(0.05, -0.02, 0.01), shear=(0.01, 0, 0))},
                                     {"bottom": Bottom(depth=0.6)}], ids=["plain", "current", "bottom"])
def test_two_threads_give_the_one_thread_batch_bit_for_bit(options):
    model = fleet_model(**options)
    x0, cmd = scattered(model)
    one = run_on(1, model, x0, cmd, record_every=3)
    two = run_on(2, model, x0, cmd, record_every=3)
    assert_same(one, two)
    assert np.abs(np.diff(two.x[-1], axis=0)).max() > 1e-3      # the vehicles differ
    if "bottom" in options:
        assert np.isfinite(two.landed_at).all()                 # every contact branch ran


@two_threads
@pytest.mark.parametrize("n", [1, 2, 5, 9])
def test_shares_of_any_size_give_the_same_vehicles(n):
    # n = 1 leaves a thread idle; 5 and 9 split unevenly
    model = Model(None, n=n)
    x0, cmd = scattered(model, seed=n)
    assert_same(run_on(1, model, x0, cmd), run_on(2, model, x0, cmd))


@pytest.mark.parametrize("threads", [1, pytest.param(2, marks=two_threads)])
def test_the_batch_is_the_serial_step_repeated(threads):
    # kernels.rk4 is the serial, one-step kernel a controller in lockstep uses
    model = fleet_model()
    x0, cmd = scattered(model, seed=7)
    run = run_on(threads, model, x0, cmd)
    x = x0.copy()
    for k in range(1, len(run.t)):
        x = model.step(x, cmd, 0.01)
        assert np.array_equal(run.x[k], x), k


@two_threads
def test_a_vehicle_in_a_parallel_batch_is_the_vehicle_alone():
    model = fleet_model()
    x0, cmd = scattered(model, seed=11)
    together = run_on(2, model, x0, cmd, record_every=5)
    for i in (0, 3, 6):
        alone = run_on(1, model.single(i), x0[i:i + 1], cmd[i:i + 1], record_every=5)
        assert np.array_equal(together.x[:, i], alone.x[:, 0]), i
        assert np.array_equal(together.specific_force_imu[:, i], alone.specific_force_imu[:, 0]), i


def test_the_batch_splits_into_one_share_a_thread_and_one_on_one_thread():
    # a campaign worker sets one thread (one process a core): the kernel
    # must then not start a second
    numba.set_num_threads(1)
    assert kernels.shares(9) == 1
    if numba.config.NUMBA_NUM_THREADS >= 2:
        numba.set_num_threads(2)
        assert (kernels.shares(9), kernels.shares(1)) == (2, 1)


def bench(*args: str):
    return subprocess.run([sys.executable, "-m", "roboray.sim.cli", "bench", "dynamics", *args],
                          capture_output=True, text=True, timeout=300)


@two_threads
def test_bench_reports_one_and_n_threads_and_the_compile_time_apart():
    proc = bench("--duration", "1", "--batch", "9", "--batch-duration", "0.3", "--threads", "2", "--repeat", "2",
                 "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["threads"] == 2 and out["repeats"] == 2
    assert out["threading_layer"] in ("tbb", "omp", "workqueue")
    assert out["identical_across_threads"] is True
    assert out["vehicle_seconds_per_second"] >= out["vehicle_seconds_per_second_median"] > 0
    assert out["vehicle_seconds_per_second_1_thread"] >= out["vehicle_seconds_per_second_1_thread_median"] > 0
    assert out["speedup"] == pytest.approx(out["vehicle_seconds_per_second"]
                                           / out["vehicle_seconds_per_second_1_thread"], rel=1e-3)
    assert out["compile_s"] > 0 and isinstance(out["kernels_from_cache"], bool)
    assert out["cpu_us_per_vehicle_second"] > 0


@pytest.mark.parametrize("value", ["0", "two", "-1"])
def test_bench_refuses_a_thread_count_in_one_line(value):
    proc = bench("--threads", value)
    assert proc.returncode == 2
    assert "--threads" in proc.stderr and "Traceback" not in proc.stderr and len(proc.stderr.splitlines()) == 1


def test_bench_refuses_more_threads_than_numba_has():
    proc = bench("--threads", str(numba.config.NUMBA_NUM_THREADS + 1))
    assert proc.returncode == 2
    assert "NUMBA_NUM_THREADS" in proc.stderr and "Traceback" not in proc.stderr
