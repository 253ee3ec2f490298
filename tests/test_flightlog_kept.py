"""The flight log's ring in RAM a watchdog reset keeps (RoboRay's builds:
``logram``, ``boards/pico2.py log_ram``): a reset mid-dive keeps the dive's
records, a power cut loses them (issue 26 item 5). The twin's end-to-end
runs are in ``test_flightlog_twin.py``."""

from __future__ import annotations

import struct

from pymavlink import DFReader

from roboray.firmware.flightlog import files as F
from roboray.firmware.flightlog import logger as L
from roboray.firmware.param_store import Files
from roboray.shared import param_defs
from roboray.shared.mavlink.telemetry import Telemetry
from roboray.shared.params import ParamTable
from roboray.tools.micropython import rp2350_emu

STEP_US = 20_000
#: logram's size in RoboRay's builds (tools/roboray_micropython/mpconfig_roboray.h)
RAM_BYTES = 80 * 1024 + 128


class Life:
    """One life of the board: a new logger on the same flash and the same RAM."""

    def __init__(self, root, ram, watchdog_reset):
        self.us = 0          # the board's clock starts again at each reset
        self.params = ParamTable(param_defs.PARAMS + L.PARAMS)
        self.t = Telemetry()
        self.stalls: list[int] = []
        self.files = F.LogFiles(Files(), root=str(root / "logs"))
        self.log = L.FlightLog(self.params, self.t, self.files, lambda: self.us, lambda a, b: a - b,
                               expect_delay=self.stalls.append, ram=ram, watchdog_reset=watchdog_reset)

    def run(self, seconds, armed, descent=0.0, depth=3.0):
        for _ in range(int(seconds * 1e6 / STEP_US)):
            self.us += STEP_US
            self.t.vel_ned[2] = descent
            self.t.env[0] = depth
            self.log.step(armed)


def dive_until_reset(root, ram):
    a = Life(root, ram, watchdog_reset=False)
    a.run(4.0, armed=False, depth=0.0)       # log 1 prepared on deck
    a.run(1.0, armed=True, depth=0.0)
    a.run(10.0, armed=True, descent=0.3)     # the reset comes in the descent
    assert a.files.size(1) > 0 and a.log.w.pending() > 20_000     # all in RAM
    return a


def records(path):
    log = DFReader.DFReader_binary(str(path))
    out = []
    while (m := log.recv_match()) is not None:
        out.append(m)
    return out


def test_the_region_is_the_builds_size():
    assert rp2350_emu.log_ram_bytes() == RAM_BYTES


def test_a_watchdog_reset_mid_dive_keeps_the_dives_records_in_the_same_log(tmp_path):
    ram = bytearray(RAM_BYTES)
    first = dive_until_reset(tmp_path, ram)
    before = first.files.size(1)
    pending = first.log.w.pending()
    b = Life(tmp_path, ram, watchdog_reset=True)
    assert b.log.kept_bytes == pending
    assert "kept over the reset" in b.log.describe()
    b.run(1.0, armed=False, descent=0.3)       # booting, not yet re-armed: nothing to flash in the water
    assert b.stalls == [] and b.files.size(1) == before
    b.run(10.0, armed=True, descent=0.3)       # re-armed (firmware/resume.py), still descending
    assert b.stalls == []
    b.run(8.0, armed=True)                     # on the bottom: flushed into log 1
    b.run(5.0, armed=False)
    assert b.files.numbers()[0] == 1 and b.files.size(1) > before + pending
    msgs = records(tmp_path / "logs" / "00000001.BIN")
    att = [m.TimeUS for m in msgs if m.get_type() == "ATT"]
    assert len(att) > 25 * 25                  # both lives' dive: 10 s before the reset, 18 s after
    assert att == sorted(att)                  # the time goes on from the last record kept
    texts = [m.Message for m in msgs if m.get_type() == "MSG"]
    assert "watchdog reset: log continues" in texts
    events = [m.Id for m in msgs if m.get_type() == "EV"]
    assert events[:2] == [L.EV_ARMED, L.EV_ARMED] and L.EV_DISARMED in events


def test_a_power_cut_loses_the_dive_since_arming(tmp_path):
    ram = bytearray(RAM_BYTES)
    first = dive_until_reset(tmp_path, ram)
    before = first.files.size(1)
    ram[:] = bytes(RAM_BYTES)                  # the supply went: the twin zeroes it (machine.py)
    b = Life(tmp_path, ram, watchdog_reset=False)
    assert b.log.kept_bytes == 0
    b.run(25.0, armed=False)
    assert b.files.size(1) == before           # its header and parameters only


def test_a_power_on_ignores_what_ram_still_holds(tmp_path):
    # a short cut may leave SRAM readable: only a watchdog reset trusts it
    ram = bytearray(RAM_BYTES)
    first = dive_until_reset(tmp_path, ram)
    before = first.files.size(1)
    b = Life(tmp_path, ram, watchdog_reset=False)
    assert b.log.kept_bytes == 0
    b.run(25.0, armed=False)
    assert b.files.size(1) == before
    c = Life(tmp_path, ram, watchdog_reset=True)   # nor does a later reset bring it back
    assert c.log.kept_bytes == 0


def test_a_reset_in_the_middle_of_saving_the_state_keeps_the_other_copy(tmp_path):
    ram = bytearray(RAM_BYTES)
    first = dive_until_reset(tmp_path, ram)
    w = first.log.w
    # the last save went to one copy; tear it as a reset in the middle of the write would
    last = first.log._ctl + (first.log._seq & 1) * L._CTL_BYTES
    ram[last + 8:last + 12] = struct.pack("<I", 12345)
    b = Life(tmp_path, ram, watchdog_reset=True)
    # the copy before it: one call's records (at most two) fewer
    assert 0 < w.pending() - b.log.kept_bytes <= 2 * L.IMU.length


def test_stock_builds_keep_todays_ring_and_say_so(tmp_path):
    b = Life(tmp_path, None, watchdog_reset=True)
    assert b.log.ram is None and b.log.kept_bytes == 0 and len(b.log.w.buf) == b.log.ring_kb * 1024 == 80 * 1024
    assert "no RAM kept across a reset" in b.log.describe()
