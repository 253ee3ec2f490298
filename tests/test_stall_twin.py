"""A planned stall in flight (the TARGET entry's parameter save, ~150 ms)
leaves the IMU's FIFO past one read, so the IMU is silent ~160 ms with
nothing wrong. The attitude held over it stays valid: the controller goes
on slewing the wings. It used to drop the estimate's validity until the
next 10 Hz housekeeping, and the controller parked the wings at PASSIVE for
those steps: a jump at 230 deg/s right after the save (CTL_SLEW_DPS 60)."""

from __future__ import annotations

import numpy as np
from pymavlink import DFReader

from roboray.sim.twin.runner import Options, run


def test_the_wings_keep_their_slew_through_the_target_entrys_save(tmp_path):
    r = run(Options(scenario="target-landing", seed=1, interpreter="cpython", depth=4.0, target=(1.2, 0.6),
                    vehicle="sim/vehicles/buildable.py", board_fs=str(tmp_path)))
    assert [m for _, m in r["modes"]] == ["PASSIVE", "TARGET"] and r["failsafes"] == []
    log = DFReader.DFReader_binary(str(tmp_path / "logs" / "00000001.BIN"))
    rows = []
    while (m := log.recv_match(type="WING")) is not None:
        rows.append((m.TimeUS * 1e-6, m.Cmd1, m.Cmd2, m.Cmd3, m.Cmd4))
    w = np.array(rows)
    assert len(w) > 50
    rate = np.abs(np.diff(w[:, 1:], axis=0)) / np.diff(w[:, 0])[:, None]
    # 60 deg/s commanded; a 5 Hz record is stamped up to a slot or two off
    # its command's time (70.8 deg/s at most over this dive)
    assert rate.max() < 100.0, (rate.max(), w[np.argmax(rate.max(axis=1))])
