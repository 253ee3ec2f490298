"""The DataFlash format: what the board packs, pymavlink's DFReader reads back, units included."""

from __future__ import annotations

import struct

import pytest
from pymavlink import DFReader

from roboray.firmware.flightlog import dataflash as df

ATT = df.Record(150, "ATT", "Qffffff", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw", "sdddddh", "F000000")
IMU = df.Record(151, "IMU", "QBffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ", "s#EEEooo", "F-000000")


def _att(w, yaw):
    o = w.reserve(ATT.length)
    if o >= 0:
        struct.pack_into(ATT.pack, w.buf, o, df.HEAD1, df.HEAD2, ATT.type_id,
                         w.t0, w.t1, w.t2, w.t3, 1.0, 2.0, 3.0, 4.0, 5.0, yaw)
    return o


def _drain(w, most=4096):
    out = bytearray()
    while w.pending():
        o, n = w.chunk(most)
        out += w.buf[o:o + n]
        w.taken(n)
    return bytes(out)


def _read(tmp_path, w):
    path = tmp_path / "00000001.BIN"
    path.write_bytes(_drain(w))
    return DFReader.DFReader_binary(str(path))


def test_records_read_back_with_their_time_and_units(tmp_path):
    w = df.Writer(20000)
    clock = df.Clock()
    clock.set_us(5_000_000_000)     # past 2**32 us: the time's upper parts are exercised
    w.stamp(clock)
    assert w.header((ATT, IMU))
    for i in range(100):
        clock.advance(40_000)
        w.stamp(clock)
        assert _att(w, float(i)) >= 0
        o = w.reserve(IMU.length)
        struct.pack_into(IMU.pack, w.buf, o, df.HEAD1, df.HEAD2, IMU.type_id,
                         w.t0, w.t1, w.t2, w.t3, 0, 0.1, 0.2, 0.3, 0.0, 0.0, -9.8)
    log = _read(tmp_path, w)
    seen = []
    while True:
        m = log.recv_match(type=["ATT", "IMU"])
        if m is None:
            break
        seen.append(m)
    atts = [m for m in seen if m.get_type() == "ATT"]
    assert len(atts) == 100 and len(seen) == 200
    assert [m.TimeUS for m in atts] == [5_000_000_000 + 40_000 * (i + 1) for i in range(100)]
    assert [m.Yaw for m in atts] == [float(i) for i in range(100)] and atts[0].Pitch == 4.0
    fmt = log.formats[log.name_to_id["IMU"]]
    assert fmt.units == ["µs", "instance", "rad/s", "rad/s", "rad/s", "m/s/s", "m/s/s", "m/s/s"]
    assert log.formats[log.name_to_id["ATT"]].units[-1] == "degheading"


def test_clock_carries_into_its_upper_part():
    c = df.Clock()
    c.set_us((1 << 24) - 5)
    c.advance(10)
    assert (c.hi, c.lo) == (1, 5) and c.us() == (1 << 24) + 5
    c.advance(1 << 29)      # a long stall: several carries at once
    assert c.us() == (1 << 24) + 5 + (1 << 29) and c.lo < (1 << 24)


def test_a_full_buffer_drops_new_records_and_keeps_the_old(tmp_path):
    w = df.Writer(3000)
    w.stamp(df.Clock())
    assert w.header((ATT,))
    kept = 0
    while _att(w, float(kept)) >= 0:
        kept += 1
    for _ in range(5):
        assert _att(w, -1.0) == -1
    assert w.dropped == 6 and w.free() <= ATT.length
    yaws = []
    log = _read(tmp_path, w)
    while (m := log.recv_match(type="ATT")) is not None:
        yaws.append(m.Yaw)
    assert yaws == [float(i) for i in range(kept)]


def test_a_buffer_too_small_for_the_header_says_so():
    w = df.Writer(500)
    assert not w.header((ATT, IMU))


@pytest.mark.parametrize("args", [
    (152, "LONGNAME", "Qf", "TimeUS,X", "s-", "F-"),        # name over 4 letters
    (152, "X", "Qf", "TimeUS,X,Y", "s-", "F-"),             # labels and fields disagree
    (152, "X", "fQ", "X,TimeUS", "-s", "-F"),               # TimeUS not first
    (152, "X", "Qf", "TimeUS,X", "s", "F-"),                # a unit missing
])
def test_a_malformed_record_is_refused(args):
    with pytest.raises(ValueError, match="record"):
        df.Record(*args)


def test_the_board_packs_the_same_bytes_and_allocates_nothing_a_record(micropython):
    micropython.exec(
        "import struct\n"
        "from roboray.firmware.flightlog import dataflash as df\n"
        "__A = df.Record(150, 'ATT', 'Qffffff', 'TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw', 'sdddddh', 'F000000')\n"
        "__w = df.Writer(4000)\n__c = df.Clock()\n__c.set_us(5000000000)\n__w.stamp(__c)\n"
        "__ok = __w.header((__A,))\n"
        "__v = [1.0, 2.0]\n"
        "def __rec():\n"
        "    __c.advance(40000)\n"
        "    __w.stamp(__c)\n"
        "    o = __w.reserve(__A.length)\n"
        "    struct.pack_into(__A.pack, __w.buf, o, 0xA3, 0x95, 150, __w.t0, __w.t1, __w.t2, __w.t3,"
        " __v[0], __v[1], __v[0], __v[1], __v[0], __v[1])\n")
    assert micropython.eval("__ok")
    micropython.exec("__rec()")
    board = bytes(micropython.eval("list(__w.buf[:__w.head])"))
    w = df.Writer(4000)
    c = df.Clock()
    c.set_us(5_000_000_000)
    w.stamp(c)
    assert w.header((ATT,))
    c.advance(40_000)
    w.stamp(c)
    o = w.reserve(ATT.length)
    struct.pack_into(ATT.pack, w.buf, o, 0xA3, 0x95, 150, w.t0, w.t1, w.t2, w.t3, 1.0, 2.0, 1.0, 2.0, 1.0, 2.0)
    assert board == bytes(w.buf[:w.head])
    assert micropython.alloc_bytes("__rec()") == 0


def test_the_ring_keeps_records_whole_and_in_order_across_wraps(tmp_path):
    """Records written while older ones are taken to flash, over several
    wraps: every record comes out once, whole, in order; none is dropped
    while the flushing keeps up."""
    w = df.Writer(4000)
    w.stamp(df.Clock())
    assert w.header((ATT,))
    out = bytearray(_drain(w))
    wraps = 0
    for i in range(400):
        before = w.head
        assert _att(w, float(i)) >= 0, i
        wraps += w.head < before
        if i % 7 == 6:   # a flush of at most 200 bytes now and then
            o, n = w.chunk(200)
            out += w.buf[o:o + n]
            w.taken(n)
    out += _drain(w, most=64)
    assert wraps >= 3 and w.dropped == 0 and w.pending() == 0
    path = tmp_path / "ring.BIN"
    path.write_bytes(bytes(out))
    log = DFReader.DFReader_binary(str(path))
    yaws = []
    while (m := log.recv_match(type="ATT")) is not None:
        yaws.append(m.Yaw)
    assert yaws == [float(i) for i in range(400)]
