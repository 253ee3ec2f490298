"""``roboray-sim bench drivers`` reports the hardware layer's costs."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest


@pytest.mark.micropython
def test_bench_drivers_reports_every_task_and_the_loop():
    proc = subprocess.run(
        [sys.executable, "-m", "roboray.sim.cli", "bench", "drivers", "--calls", "20", "--slots", "100", "--json"],
        capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    tasks = r["tasks"]
    assert set(tasks) >= {"imu", "depth", "servos", "radio", "battery", "leak", "ms5837_compensate"}
    # allocation figures are exact and the ones the driver tests hold
    assert tasks["depth"]["heap_bytes"] == 0 and tasks["ms5837_compensate"]["heap_bytes"] == 0
    assert tasks["radio"]["heap_bytes"] == 0 and tasks["leak"]["heap_bytes"] == 0
    assert tasks["imu"]["heap_bytes"] <= 13 * 16
    # the FIFO's status (2 bytes), one sample of each sensor (2 words of 7),
    # the magnetometer (9) at 400 kHz
    assert tasks["imu"]["i2c_us"] == pytest.approx(787.5)
    assert r["slots"] == 100 and r["overruns"] == 0 and r["sensors_healthy"] == [True] * 4
    assert r["loop_real_time_factor"] > 1 and r["slot_heap_bytes"] > 0
