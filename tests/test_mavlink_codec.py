"""The board's MAVLink codec against pymavlink, message for message."""

from __future__ import annotations

import random
import struct

import pytest
from pymavlink.dialects.v20 import development as pm  # common.xml and the standard modes

from roboray.shared.mavlink import crc
from roboray.shared.mavlink import messages as M
from roboray.shared.mavlink.parser import SIG_BAD, SIG_CUT, SIG_NONE, SIG_OK, SIG_UNCHECKED, Parser
from roboray.shared.mavlink.signing import Signing, key_from_passphrase
from roboray.tools import mavgen

from test_mavlink_helpers import (MSGIDS, flat, our_encode, pymavlink_decode, pymavlink_encode,
                                  random_fields, same_value)

KEY = key_from_passphrase("roboray test passphrase")
TIMESTAMP = 0x123456789AB  # 10 us units since 2015


def test_generated_module_is_what_the_generator_writes_today():
    committed = mavgen.default_out().read_text()
    assert mavgen.generate(mavgen.default_xml()) == committed, "run python -m roboray.tools.mavgen"


def test_table_matches_pymavlink_crc_extra_order_and_lengths():
    for msgid, entry in M.TABLE.items():
        cls = pm.mavlink_map[msgid]
        assert entry[M.NAME] == cls.msgname
        assert entry[M.CRC_EXTRA] == cls.crc_extra, entry[M.NAME]
        assert list(entry[M.FIELDS]) == cls.ordered_fieldnames, entry[M.NAME]
        assert struct.calcsize(entry[M.FMT]) == entry[M.MAX_LEN] == cls.unpacker.size
    assert len(M.TABLE) >= 22


def test_crc_fast_path_equals_the_board_table_loop():
    rng = random.Random(1)
    for _ in range(300):
        data = bytes(rng.getrandbits(8) for _ in range(rng.randint(0, 300)))
        init = rng.getrandbits(16)
        assert crc.accumulate(init, data, 0, len(data)) == crc.table_accumulate(init, data, 0, len(data))
    # the MCRF4XX check value ("123456789" -> 0x6F91)
    assert crc.table_accumulate(0xFFFF, b"123456789", 0, 9) == 0x6F91


def test_crc_table_loop_over_any_slice_equals_byte_by_byte():
    # the loop takes four bytes a pass and the rest singly: every start and length
    data = bytes(range(7, 250, 13))
    for start in range(0, 6):
        for end in range(start, len(data) + 1):
            want = 0xFFFF
            for b in data[start:end]:
                want = crc.accumulate_byte(want, b)
            assert crc.table_accumulate(0xFFFF, data, start, end) == want, (start, end)


def _decode_ours(frame: bytes, key: bytes | None = None) -> tuple[Parser, dict]:
    p = Parser(Signing(key) if key else None)
    end = p.feed(frame)
    assert p.ready and end == len(frame)
    values = struct.unpack_from(p.entry[M.FMT], p.payload, 0)
    out, k = {}, 0
    for name, n in zip(p.entry[M.FIELDS], p.entry[M.ARRAYS]):
        if n:
            out[name] = list(values[k:k + n])
            k += n
        else:
            out[name] = values[k]
            k += 1
    return p, out


CASES = [(msgid, v1, signed) for msgid in MSGIDS for v1 in (False, True) for signed in (False, True)
         if not (v1 and signed) and not (v1 and msgid > 255)]   # MAVLink 1: ids 0-255


@pytest.mark.parametrize("msgid,mavlink1,signed", CASES,
                         ids=lambda x: M.TABLE[x][M.NAME] if isinstance(x, int) and not isinstance(x, bool) and x in M.TABLE else str(x))
def test_both_ways_with_pymavlink(msgid, mavlink1, signed):
    rng = random.Random(msgid * 4 + mavlink1 * 2 + signed)
    has_ext = M.TABLE[msgid][M.MIN_LEN] != M.TABLE[msgid][M.MAX_LEN]
    key = KEY if signed else None
    for trial in range(12):
        values = random_fields(msgid, rng)
        if mavlink1 and has_ext:
            for name in M.TABLE[msgid][M.FIELDS][_base_fields(msgid):]:
                values[name] = [0] * len(values[name]) if isinstance(values[name], list) else (
                    b"" if isinstance(values[name], bytes) else 0)
        seq, sysid, compid = rng.randrange(256), rng.randrange(1, 256), rng.randrange(256)
        kw = dict(mavlink1=mavlink1, key=key, link_id=7, timestamp=TIMESTAMP + trial)
        ours = our_encode(msgid, values, seq, sysid, compid, **kw)
        theirs = pymavlink_encode(msgid, values, seq, sysid, compid, **kw)
        if mavlink1 and has_ext:
            # pymavlink puts the extension bytes into MAVLink 1 frames; the
            # specification (and the C library, and we) send the base fields only
            assert ours[1] == M.TABLE[msgid][M.MIN_LEN] and theirs[1] == M.TABLE[msgid][M.MAX_LEN]
        else:
            assert ours == theirs, "%s differs from pymavlink" % M.TABLE[msgid][M.NAME]
        # pymavlink decodes ours
        m = pymavlink_decode(ours, key)
        assert m.get_msgId() == msgid and m.get_seq() == seq and m.get_srcSystem() == sysid
        for name, v in values.items():
            assert same_value(getattr(m, name), v), name
        if signed:
            assert m.get_signed() and m.get_link_id() == 7
        # we decode pymavlink's
        p, decoded = _decode_ours(theirs, key)
        assert (p.msgid, p.seq, p.sysid, p.compid, p.mavlink1) == (msgid, seq, sysid, compid, mavlink1)
        assert p.signed == signed and p.sig_ok == signed
        for name, v in values.items():
            assert same_value(decoded[name].rstrip(b"\0") if isinstance(decoded[name], bytes) else decoded[name], v), name


def _base_fields(msgid: int) -> int:
    # base fields come first in wire order; count them from their wire length
    entry = M.TABLE[msgid]
    size, count = 0, 0
    for name in entry[M.FIELDS]:
        if size >= entry[M.MIN_LEN]:
            break
        fmt = "<" + _field_fmt(entry, name)
        size += struct.calcsize(fmt)
        count += 1
    return count


def _field_fmt(entry, name):
    from test_mavlink_helpers import _codes

    count, code = _codes(entry[M.FMT])[list(entry[M.FIELDS]).index(name)]
    return "%d%s" % (count, code)


def test_truncated_payload_decodes_with_zeros():
    # MAVLink 2 drops trailing zeros: the parser must give them back
    values = {"time_boot_ms": 77, "roll": 0.5, "pitch": 0.0, "yaw": 0.0,
              "rollspeed": 0.0, "pitchspeed": 0.0, "yawspeed": 0.0}
    frame = our_encode(M.MSG_ATTITUDE, values, 1, 1, 1)
    assert frame[1] < M.ATTITUDE_LEN
    p, decoded = _decode_ours(frame)
    assert decoded["roll"] == 0.5 and decoded["yawspeed"] == 0.0 and p.length == frame[1]


def test_a_buffer_of_many_frames_and_single_bytes_give_the_same_frames():
    rng = random.Random(5)
    frames = [our_encode(mid, random_fields(mid, rng), i & 0xFF, 1, 1) for i, mid in
              enumerate(rng.choice(MSGIDS) for _ in range(200))]
    stream = b"".join(frames)
    a, b = Parser(), Parser()
    got_a, got_b = [], []
    i = 0
    while i < len(stream):
        i = a.feed(stream, i, len(stream))
        if a.ready:
            got_a.append(bytes(a.frame()))
    for byte in stream:
        if b.parse_byte(byte):
            got_b.append(bytes(b.frame()))
    assert got_a == got_b == frames
    assert a.frames == 200 and a.lost == 0 and a.crc_errors == 0 and a.garbage == 0


def test_lost_frames_are_counted_from_sequence_numbers():
    rng = random.Random(9)
    frames = [our_encode(M.MSG_HEARTBEAT, random_fields(0, rng), seq & 0xFF, 1, 1) for seq in range(300)]
    kept = [f for i, f in enumerate(frames) if i % 10 != 3]  # drop 30
    p = Parser()
    data = b"".join(kept)
    i = 0
    while i < len(data):
        i = p.feed(data, i, len(data))
    assert p.frames == 270 and p.lost == 30


#: The frames both sides build: the same source on the emulated board and here.
_BUILD_FRAMES = r'''
def build_frames(frame, M, Signing, struct):
    out = []
    for key in (None, bytes(range(32))):
        s = None
        if key is not None:
            s = Signing(key)
            s.timestamp = 123456789
        w = frame.Writer(7, 3, s)
        struct.pack_into(M.ATTITUDE_FMT, w.buf, w.payload, 1234, 0.1, -0.2, 0.3, 0.0, 0.0, 0.0)
        out.append(bytes(w.view(w.finish(M.MSG_ATTITUDE))))
        struct.pack_into(M.HEARTBEAT_FMT, w.buf, w.payload, 0, 0, 0, 0, 0, 0)
        out.append(bytes(w.view(w.finish(M.MSG_HEARTBEAT))))
        struct.pack_into(M.SERVO_OUTPUT_RAW_FMT, w.buf, w.payload, 5, 1500, 1501, 1502, 1503, *([0] * 13))
        out.append(bytes(w.view(w.finish(M.MSG_SERVO_OUTPUT_RAW))))
        w1 = frame.Writer(7, 3, None, mavlink1=True)
        struct.pack_into(M.HEARTBEAT_FMT, w1.buf, w1.payload, 1, 2, 3, 4, 5, 6)
        out.append(bytes(w1.view(w1.finish(M.MSG_HEARTBEAT))))
    return out
'''

_NATIVE_FRAMES = r'''
import struct
from roboray.shared.mavlink import messages as M, frame, crc
from roboray.shared.mavlink.parser import Parser
from roboray.shared.mavlink.signing import Signing
print("NATIVE", crc.v2_finish is not None and crc.viper_accumulate is not None)
''' + _BUILD_FRAMES + r'''
out = build_frames(frame, M, Signing, struct)
p = Parser()
for f in out:
    i = 0
    while i < len(f):
        i = p.feed(f, i, len(f))
print("PARSED", p.frames, p.crc_errors, p.garbage)
for f in out:
    print("F " + f.hex())
'''


class _Struct30:
    """``struct`` as a RoboRay board packs: each float argument is first the
    30-bit float the board holds (``roboray_host.float30``), so its float32
    field is not CPython's for 0.1 (0x3dcccccf, not 0x3dcccccd)."""

    @staticmethod
    def pack_into(fmt, buf, offset, *values):
        from roboray.tools.micropython.roboray_host import float30

        struct.pack_into(fmt, buf, offset, *(float30(v) if isinstance(v, float) else v for v in values))


@pytest.mark.parametrize("build", ["roboray", "stock"])
def test_the_boards_native_framing_and_checksum_give_the_same_bytes(tmp_path, build):
    """On the emulated RP2350 the checksum and the MAVLink 2 header are compiled
    (``@micropython.viper``, crc.py); its frames are byte for byte CPython's
    for the values it holds: float32 on stock, 30-bit floats on RoboRay's
    build (REPR_C)."""
    from roboray.shared.mavlink import frame
    from roboray.tools.micropython import rp2350_emu

    if not rp2350_emu.available(build):
        pytest.skip("the emulated RP2350 needs qemu-system-arm")
    lib = rp2350_emu.install_lib(tmp_path / "lib")
    status, out = rp2350_emu.run(_NATIVE_FRAMES, tmp_path, path=(str(lib),), timeout=120, build=build)
    assert status == 0, out
    assert "NATIVE True" in out and "PARSED 8 0 0" in out
    ns: dict = {}
    exec(_BUILD_FRAMES, ns)
    want = ns["build_frames"](frame, M, Signing, _Struct30 if build == "roboray" else struct)
    if build == "roboray":   # the ATTITUDE frames differ from float32's
        assert want != ns["build_frames"](frame, M, Signing, struct)
    assert [bytes.fromhex(x[2:]) for x in out.splitlines() if x.startswith("F ")] == want


# -------------------------------------------------- damaged signatures (issue 16)
def _signed_pm(msgid: int, seq: int, rng: random.Random, ts: int) -> bytes:
    return pymavlink_encode(msgid, random_fields(msgid, rng), seq, 1, 1, key=KEY, link_id=4, timestamp=ts)


def _parse_all(data: bytes, key: bytes | None) -> list[tuple[bytes, int]]:
    s = None
    if key is not None:
        s = Signing(key)
        s.hi, s.lo = TIMESTAMP >> 24, TIMESTAMP & 0xFFFFFF   # our clock where the sender's is
    p = Parser(s)
    got = []
    i = 0
    while i < len(data):
        i = p.feed(data, i, len(data))
        if p.ready:
            got.append((bytes(p.frame()), p.sig_status))
    while p.flush():
        got.append((bytes(p.frame()), p.sig_status))
    return got


@pytest.mark.parametrize("keep", range(13))
def test_a_signature_cut_short_keeps_the_next_frame(keep):
    """pymavlink's signed frame loses signature bytes; the frame after it
    (pymavlink's too) comes out, with the key and without, and the damaged
    one is flagged, never passed on as good."""
    rng = random.Random(keep)
    signed = _signed_pm(M.MSG_ATTITUDE, 1, rng, TIMESTAMP + 1)
    nxt = pymavlink_encode(M.MSG_HEARTBEAT, random_fields(0, rng), 2, 1, 1)
    last = _signed_pm(M.MSG_LOCAL_POSITION_NED, 3, rng, TIMESTAMP + 3)
    cut = signed[:len(signed) - 13 + keep]
    data = cut + nxt + last
    damaged = data[:len(signed)]   # what the parser takes as the signed frame
    with pytest.raises(Exception, match="[Ss]ignature"):
        pymavlink_decode(damaged, KEY)   # the reference refuses it too
    assert _parse_all(data, KEY) == [(damaged, SIG_BAD), (nxt, SIG_NONE), (last, SIG_OK)]
    assert _parse_all(data, None) == [(damaged, SIG_CUT), (nxt, SIG_NONE), (last, SIG_UNCHECKED)]


def test_a_signature_changed_in_place_is_refused_with_the_key_only():
    rng = random.Random(2)
    signed = bytearray(_signed_pm(M.MSG_ATTITUDE, 1, rng, TIMESTAMP + 1))
    nxt = pymavlink_encode(M.MSG_HEARTBEAT, random_fields(0, rng), 2, 1, 1)
    for at in range(len(signed) - 13, len(signed)):
        bad = bytearray(signed)
        bad[at] ^= 0x10
        if bad[at] in (0xFD, 0xFE):
            continue
        data = bytes(bad) + nxt
        assert _parse_all(data, KEY) == [(bytes(bad), SIG_BAD), (nxt, SIG_NONE)]
        # no key: nothing says it is damaged; it is unchecked, not good
        assert _parse_all(data, None) == [(bytes(bad), SIG_UNCHECKED), (nxt, SIG_NONE)]


def _signed_ending_in_a_start_byte() -> bytes:
    """A good signed frame whose signature's last byte is a start byte (its
    hash: found by trying timestamps)."""
    rng = random.Random(4)
    values = random_fields(M.MSG_ATTITUDE, rng)
    for ts in range(TIMESTAMP, TIMESTAMP + 5000):
        f = pymavlink_encode(M.MSG_ATTITUDE, values, 1, 1, 1, key=KEY, link_id=4, timestamp=ts)
        if f[-1] == 0xFD:
            return f
    raise AssertionError("no signature ends in 0xFD")


def test_without_the_key_a_start_byte_at_the_signatures_end_waits_for_what_follows():
    f = _signed_ending_in_a_start_byte()
    nxt = our_encode(M.MSG_HEARTBEAT, random_fields(0, random.Random(1)), 2, 1, 1)
    # with the key: verified and delivered at once
    s = Signing(KEY)
    s.hi, s.lo = TIMESTAMP >> 24, TIMESTAMP & 0xFFFFFF
    p = Parser(s)
    assert p.feed(f) == len(f) and p.ready and p.sig_status == SIG_OK
    # without: the header of a frame may begin there; its bytes decide
    p = Parser()
    assert p.feed(f) == len(f) and not p.ready
    i = p.feed(nxt, 0, 2)
    assert i == 2 and not p.ready   # no flags byte yet
    i = p.feed(nxt, i, len(nxt))
    assert p.ready and p.sig_status == SIG_UNCHECKED and bytes(p.frame()) == f
    i = p.feed(nxt, i, len(nxt))
    assert p.ready and bytes(p.frame()) == nxt and p.sig_status == SIG_NONE
    # at the end of the input, flush() decides on what is there
    p = Parser()
    p.feed(f)
    assert not p.ready and p.flush() and p.sig_status == SIG_UNCHECKED and bytes(p.frame()) == f
    assert not p.flush()


def test_the_tlog_decoder_reads_such_a_frame_without_the_key():
    from roboray.ground.tlog import Decoder

    f = _signed_ending_in_a_start_byte()
    out = Decoder().decode(f)
    assert out["mavpackettype"] == "ATTITUDE" and out["crc_ok"] is True
    out = Decoder(KEY).decode(f)
    assert out["crc_ok"] is True and out["signature_ok"] is True


def test_ids_above_255_are_framed_and_parsed_and_unknown_ones_refused():
    """WIRE_HIGH: SETUP_SIGNING, AVAILABLE_MODES and CURRENT_MODE have their
    bytes after the dense part; an id above 255 the table lacks (437,
    AVAILABLE_MODES_MONITOR) is refused by the framer and skipped by the
    parser, which finds the frame after it."""
    from roboray.shared.mavlink.frame import Writer

    assert [M.wire_high(m) for m in (256, 435, 436)] == [768, 771, 774]
    assert M.wire_high(437) == M.wire_high(-1) == M.wire_high(1 << 24) == 777 == len(M.WIRE) - 3
    assert M.WIRE[777:780] == b"\0\0\0"
    w = Writer(1, 1)
    for bad in (437, -1, 300, 1 << 24):
        with pytest.raises(KeyError):
            w.finish(bad)
    mav = pm.MAVLink(None, 1, 1)
    stream = (pm.MAVLink_available_modes_monitor_message(3).pack(mav)
              + pm.MAVLink_current_mode_message(0, 19, 19).pack(mav)
              + pm.MAVLink_heartbeat_message(12, 0, 1, 19, 3, 3).pack(mav))
    p = Parser()
    got = []
    i = 0
    while i < len(stream):
        i = p.feed(stream, i, len(stream))
        if p.ready:
            got.append(p.msgid)
    assert got == [436, 0] and p.unknown == 1
