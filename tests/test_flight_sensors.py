"""The closed loop's sensors are the sensor models: run as the truth arrives
(``flight.SensorStream``, ``flight.TickFeed``), they give the samples and
the firmware calls that ``estimation.simulate_sensors`` and
``estimation.schedule`` give on the whole truth at once."""

from __future__ import annotations

import numpy as np
import pytest

from roboray.sim import estimation as E
from roboray.sim import flight as F
from roboray.sim.sensors import trajectory

SEED = 11


@pytest.fixture(scope="module")
def truth():
    """A feathering descent with wing motions, 10 s held then 4 s, at 200 Hz."""
    return trajectory.descent(SEED, trajectory.DescentProfile(hold_s=10.0, flight_s=4.0, rate_hz=200.0))


@pytest.fixture(scope="module")
def streamed(truth):
    """The stream fed four truth rows at a time, asked for its samples and
    ticks as it goes."""
    stream = F.SensorStream(truth.t, SEED, truth.imu_position_body)
    feed = F.TickFeed(stream)
    ticks = []
    k = 0
    tick = 0
    n = len(truth.t)
    while k < n:
        k1 = min(n, k + 4)
        stream.set_rows(k, k1, truth.position_ned[k:k1], truth.quaternion[k:k1], truth.omega_body[k:k1],
                        truth.specific_force_imu[k:k1], truth.depth_sensor[k:k1], truth.wing_rates[k:k1])
        k = k1
        while feed.tick_time(tick) <= truth.t[k - 1] and feed.tick_time(tick) < truth.t[-1] - 0.01:
            ticks.append(feed.events(tick, [0.0, 0.0, 0.0, 0.0]))
            tick += 1
    stream.produce(float(truth.t[-1]))
    return stream, ticks


def test_every_sample_is_the_batch_models_sample(truth, streamed):
    stream, _ = streamed
    batch = E.simulate_sensors(truth, SEED)
    logs = stream.logs()
    ins, bins = logs.inertial, batch.inertial
    assert np.array_equal(ins.t, bins.t)
    # row by row against the whole-array product: at most a rounding flip of one LSB
    for got, want, lsb in ((ins.gyro, bins.gyro, E.STANDARD.imu.gyro.lsb), (ins.accel, bins.accel, E.STANDARD.imu.accel.lsb)):
        assert got.shape == want.shape
        diff = np.abs(got - want)
        assert diff.max() <= 1.0001 * lsb
        assert np.mean(diff == 0.0) > 0.999
    assert np.array_equal(logs.mag.t, batch.mag.t)
    assert np.abs(logs.mag.field - batch.mag.field).max() <= 1.0001 * E.STANDARD.imu.mag.lsb
    assert np.allclose(logs.mag.offset, batch.mag.offset) and np.allclose(logs.mag.matrix, batch.mag.matrix)
    assert np.array_equal(logs.pressure.t, batch.pressure.t)
    assert np.array_equal(logs.pressure.t_ready, batch.pressure.t_ready)
    assert np.abs(logs.pressure.pressure_pa - batch.pressure.pressure_pa).max() <= 10.0  # one LSB
    assert np.mean(logs.pressure.pressure_pa == batch.pressure.pressure_pa) > 0.99
    assert np.allclose(logs.pressure.temperature_c, batch.pressure.temperature_c, atol=0.0101)
    assert np.array_equal(logs.fixes.t, batch.fixes.t)
    assert np.array_equal(logs.fixes.t_arrival, batch.fixes.t_arrival)
    assert np.allclose(logs.fixes.north, batch.fixes.north, atol=1e-12)
    assert np.allclose(logs.fixes.east, batch.fixes.east, atol=1e-12)
    assert logs.fixes.lost == batch.fixes.lost
    # it is a real run: samples of every kind, fixes included
    assert len(ins.t) > 2500 and len(logs.pressure.t) > 300 and len(logs.fixes.t) >= 10


def test_the_ticks_are_the_schedule_of_the_batch(truth, streamed):
    _, ticks = streamed
    batch = E.simulate_sensors(truth, SEED)
    t_ticks, calls = E.schedule(truth, batch)
    n = len(ticks)
    assert n >= len(calls) - 2
    for got, want in zip(ticks, calls[:n]):
        # the wing command comes from the controller in a closed loop, not the truth
        got = [ev for ev in got if ev[0] != "w"]
        want = [ev for ev in want if ev[0] != "w"]
        assert [ev[0] for ev in got] == [ev[0] for ev in want]
        for a, b in zip(got, want):
            assert a[1] == b[1]
            assert np.allclose(a[2:], b[2:], rtol=0, atol=1.0001 * max(E.STANDARD.imu.accel.lsb, 10.0)
                               if a[0] == "p" else 1e-3)


def test_samples_never_use_truth_that_does_not_exist_yet(truth):
    stream = F.SensorStream(truth.t, SEED, truth.imu_position_body)
    k1 = 400  # 2 s of truth
    stream.set_rows(0, k1, truth.position_ned[:k1], truth.quaternion[:k1], truth.omega_body[:k1],
                    truth.specific_force_imu[:k1], truth.depth_sensor[:k1], truth.wing_rates[:k1])
    stream.produce(5.0)   # asks for more than there is
    logs = stream.logs()
    last = truth.t[k1 - 1]
    assert logs.inertial.t[-1] <= last and logs.mag.t[-1] <= last
    assert logs.pressure.t_ready[-1] <= last and logs.fixes.t_arrival[-1] <= last
