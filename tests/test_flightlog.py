"""The on-board flight log: what a dive leaves on flash, when it is written, and what survives a reset."""

from __future__ import annotations

import os
from collections import Counter

import pytest
from pymavlink import DFReader

from roboray.firmware.flightlog import files as F
from roboray.firmware.flightlog import logger as L
from roboray.firmware.param_store import Files
from roboray.shared import param_defs
from roboray.shared.mavlink.telemetry import Telemetry
from roboray.shared.params import ParamTable

STEP_US = 20_000   # the log task's period


class Board:
    """What the logger sees of a board: a clock, telemetry, parameters, flash under ``tmp``."""

    def __init__(self, root, fs=None, bufsize_kb=64):
        self.us = 0
        self.params = ParamTable(param_defs.PARAMS + L.PARAMS)
        self.params.set_by_name("LOG_FILE_BUFSIZE", bufsize_kb)
        self.t = Telemetry()
        self.stalls: list[tuple[int, int]] = []   # (step, ms) announced
        self.step_no = 0
        self.files = F.LogFiles(fs or Files(), root=str(root / "logs"))
        self.log = L.FlightLog(self.params, self.t, self.files, lambda: self.us, lambda a, b: a - b,
                               expect_delay=lambda ms: self.stalls.append((self.step_no, ms)))

    def run(self, seconds, armed, descent=0.0, depth=1.0):
        for _ in range(int(seconds * 1e6 / STEP_US)):
            self.us += STEP_US
            self.step_no += 1
            self.t.vel_ned[2] = descent
            self.t.q[0], self.t.q[1] = 0.996, 0.087     # ~10 deg of roll
            self.t.env[0] = depth
            self.log.step(armed)


def read(path):
    log = DFReader.DFReader_binary(str(path))
    msgs = []
    while (m := log.recv_match()) is not None:
        msgs.append(m)
    return log, msgs


def test_a_dive_leaves_every_record_with_units_and_att_at_25_hz(tmp_path):
    b = Board(tmp_path, bufsize_kb=128)
    b.run(3.0, armed=False)
    b.run(2.0, armed=True)                  # held still at the surface
    b.run(25.0, armed=True, descent=0.3)    # the dive
    b.run(10.0, armed=True)                 # resting on the bottom
    b.run(5.0, armed=False)
    # log 1 the dive's; disarmed and still again, the next dive's log 2 is prepared
    assert b.log.w.dropped == 0 and b.files.numbers()[0] == 1
    log, msgs = read(tmp_path / "logs" / "00000001.BIN")
    kinds = Counter(m.get_type() for m in msgs)
    for r in L.RECORDS:
        if r.name not in ("FIX", "MODE", "ERR"):     # none happened
            assert kinds[r.name] > 0, r.name
    # ATT at 25 Hz over the whole armed time (37 s, less the ~0.4 s the
    # header takes to pack), nothing thinned
    att = [m for m in msgs if m.get_type() == "ATT"]
    assert 37 * 25 - 15 <= len(att) <= 37 * 25
    gaps = {b2.TimeUS - a.TimeUS for a, b2 in zip(att, att[1:])}
    assert gaps == {40_000}
    assert att[0].Roll == pytest.approx(10.0, abs=0.1)
    assert log.formats[log.name_to_id["IMU"]].units[2] == "rad/s"
    assert log.formats[log.name_to_id["BARO"]].units[3] == "Pa"
    assert log.formats[log.name_to_id["PM"]].units[3] == "µs"
    events = [m.Id for m in msgs if m.get_type() == "EV"]
    assert events == [L.EV_ARMED, L.EV_LAND_COMPLETE, L.EV_DISARMED]   # at rest counts from arming
    parms = {m.Name: m.Value for m in msgs if m.get_type() == "PARM"}
    assert parms["LOG_FILE_BUFSIZE"] == 128 and len(parms) == b.params.count()
    assert (tmp_path / "logs" / "LASTLOG.TXT").read_text().strip() == str(b.files.numbers()[-1])


def test_flash_is_written_only_while_the_vehicle_is_still_or_disarmed(tmp_path):
    b = Board(tmp_path)
    b.run(4.0, armed=False, depth=0.0)
    armed_at = b.step_no
    b.run(4.0, armed=True, depth=0.0)      # held still at the surface, armed: no flash
    moving_from = b.step_no
    b.run(20.0, armed=True, descent=0.3)
    moving_to = b.step_no
    b.run(8.0, armed=True)
    still_from = moving_to + L._STILL_CALLS      # the speed must stay low for STILL_S first
    writes = [s for s, _ in b.stalls]
    # the log prepared on deck before arming (header and parameters), nothing at arming
    assert [s for s in writes if s <= armed_at]
    assert not [s for s in writes if armed_at < s <= moving_from]
    assert not [s for s in writes if moving_from < s < still_from]
    assert [s for s in writes if s > still_from]          # resting: the dive goes to flash
    # every write was announced first with a stall it covers
    assert {ms for _, ms in b.stalls} <= {L.CREATE_STALL_MS, L.CHUNK_STALL_MS}


def test_a_full_buffer_thins_then_drops_new_records_and_says_so(tmp_path):
    b = Board(tmp_path, bufsize_kb=16)
    b.run(3.0, armed=False)
    b.run(0.1, armed=True)
    b.run(30.0, armed=True, descent=0.3)    # ~6 s of full-rate records fit: it fills
    dropped = b.log.w.dropped
    assert dropped > 0
    b.run(5.0, armed=True)                  # rest: flushed, and told
    b.run(3.0, armed=False)
    _, msgs = read(tmp_path / "logs" / "00000001.BIN")
    imu = [m.TimeUS for m in msgs if m.get_type() == "IMU"]
    att = [m.TimeUS for m in msgs if m.get_type() == "ATT"]
    # thinned before it filled: IMU to 5 Hz (gaps of 200 ms), ATT kept at 25 Hz
    assert 200_000 in {b2 - a for a, b2 in zip(imu, imu[1:])}
    assert 200_000 not in {b2 - a for a, b2 in zip(att, att[1:])}
    texts = [m.Message for m in msgs if m.get_type() == "MSG"]
    assert any("records dropped" in t for t in texts)
    pm = [m for m in msgs if m.get_type() == "PM"]
    assert max(m.Drop for m in pm) > 0


def test_a_reset_mid_dive_leaves_a_readable_log_and_the_next_boot_a_new_one(tmp_path):
    b = Board(tmp_path)
    b.run(4.0, armed=False)
    b.run(1.0, armed=True)
    b.run(10.0, armed=True, descent=0.3)    # the watchdog bites here: the RAM ring is lost
    fs = Files()
    b2 = Board(tmp_path, fs=fs)             # the next boot: the dive resumes armed
    b2.run(8.0, armed=True, descent=0.3)
    # nothing written while it moves (the new log's header packed in RAM only)
    assert b2.files.numbers() == [1] and not b2.stalls
    b2.run(10.0, armed=True)                # on the bottom
    assert b2.files.numbers() == [1, 2] and b2.log.w.pending() < 4096
    _, first = read(tmp_path / "logs" / "00000001.BIN")
    assert Counter(m.get_type() for m in first)["PARM"] == b.params.count()
    _, second = read(tmp_path / "logs" / "00000002.BIN")
    kinds = Counter(m.get_type() for m in second)
    assert kinds["ATT"] >= 12 * 25 and kinds["PARM"] == b.params.count()


def test_numbers_rise_across_erasures_and_wrap_after_500(tmp_path):
    lf = F.LogFiles(Files(), root=str(tmp_path / "logs"))
    assert lf.create(b"x", 1024) == 1 and lf.create(b"y", 1024) == 2
    lf.erase()
    assert lf.numbers() == [] and lf.last_number() == 0
    assert lf.create(b"z", 1024) == 1           # ArduPilot restarts at 1 after an erase too
    (tmp_path / "logs" / "LASTLOG.TXT").write_text("500\r\n")
    assert lf.create(b"w", 1024) == 1           # after 500: 1 again, replacing the oldest
    assert F.number_of("00000042.BIN") == 42 and F.number_of("notalog.BIN") == -1


class SmallFlash(Files):
    """The board's file system on a flash of ``capacity`` bytes (what statvfs reports)."""

    def __init__(self, root, capacity):
        self.root = root
        self.capacity = capacity

    def statvfs(self, path):
        used = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(self.root) for f in fs)
        blocks = self.capacity // 4096
        free = max(0, blocks - (used + 4095) // 4096)
        return (4096, 4096, blocks, free, free, 0, 0, 0, 0, 255)


def test_the_oldest_logs_go_when_the_flash_is_short_of_room(tmp_path):
    fs = SmallFlash(str(tmp_path), capacity=400 * 1024)
    lf = F.LogFiles(fs, root=str(tmp_path / "logs"))
    for _ in range(6):
        lf.create(bytes(60 * 1024), 8 * 1024)
    # a quarter of 400 kB must stay free: only the newest logs remain, oldest removed first
    assert lf.numbers()[-1] == 6 and lf.numbers()[0] > 1 and lf.removed > 0
    assert lf.free_bytes() >= 0


def test_the_logger_runs_on_micropython_and_a_step_allocates_only_floats(micropython):
    micropython.exec(
        "from roboray.firmware.flightlog import logger as L, files as F\n"
        "from roboray.firmware.param_store import Files\n"
        "from roboray.shared.params import ParamTable\n"
        "from roboray.shared import param_defs\n"
        "from roboray.shared.mavlink.telemetry import Telemetry\n"
        "import os\n"
        "try:\n    os.mkdir('/lgt')\nexcept OSError:\n    pass\n"
        "__us = [0]\n"
        "__p = ParamTable(param_defs.PARAMS + L.PARAMS)\n__p.set_by_name('LOG_FILE_BUFSIZE', 16)\n"
        "__t = Telemetry()\n"
        "__log = L.FlightLog(__p, __t, F.LogFiles(Files(), root='/lgt/logs'), lambda: __us[0],"
        " lambda a, b: a - b)\n"
        "def __go(armed, v):\n"
        "    __us[0] += 20000\n    __t.vel_ned[2] = v\n    __log.step(armed)\n"
        "for __i in range(200):\n    __go(False, 0.0)\n"
        "for __i in range(30):\n    __go(True, 0.0)\n"     # armed on deck: header, then the file
        "for __i in range(30):\n    __go(True, 0.3)\n")
    assert micropython.eval("__log.files.current") == 1
    assert micropython.eval("__log.logging")
    # boxed floats only, 16 bytes each (alloc_bytes warms up with one call,
    # then measures the next): ATT's call (quat.to_euler), and two of the
    # IMU's (with RCOU and WING, with EST)
    sizes = {}
    for n, what in ((4, "ATT"), (17, "IMU, RCOU, WING"), (13, "IMU, EST")):
        sizes[what] = micropython.alloc_bytes("__go(True, 0.3)", setup="__log._n = %d" % (n - 2))
    assert all(v % 16 == 0 for v in sizes.values()), sizes
    assert max(sizes.values()) <= 62 * 16, sizes    # (17 of them the stillness filter's: logger.STILL_TAU_S)
    head = bytes(micropython.eval("list(open('/lgt/logs/00000001.BIN', 'rb').read(3))"))
    assert head == bytes([0xA3, 0x95, 0x80])


def test_a_log_prepared_on_deck_is_used_again_and_a_changed_parameter_recorded_at_arming(tmp_path):
    b = Board(tmp_path)
    b.run(5.0, armed=False, depth=0.0)       # on deck: the next dive's log prepared
    assert b.files.numbers() == [1]
    size = b.files.size(1)
    b2 = Board(tmp_path)                     # switched off and on again, no dive
    b2.run(5.0, armed=False, depth=0.0)
    assert b2.files.numbers() == [1] and b2.files.size(1) == size     # the same number, not a new empty log
    b2.params.set_by_name("LOG_DISARMED", 0)        # (a set: the table's version moves)
    b2.params.set_by_name("SR_STATUS", 2.0)
    b2.run(1.0, armed=True, depth=0.0)       # arming writes nothing
    b2.run(3.0, armed=True, descent=0.3)
    b2.run(5.0, armed=True)
    b2.run(3.0, armed=False)
    _, msgs = read(tmp_path / "logs" / "00000001.BIN")
    sr = [m.Value for m in msgs if m.get_type() == "PARM" and m.Name == "SR_STATUS"]
    assert sr[0] != 2.0 and sr[-1] == 2.0 and len(sr) == 2
    assert [m.Id for m in msgs if m.get_type() == "EV"][0] == L.EV_ARMED
