"""MAVLink 2 signing: MAVProxy's key, pymavlink's signatures, replays refused."""

from __future__ import annotations

import hashlib
import random

from pymavlink.dialects.v20 import common as pm

from roboray.shared.mavlink import messages as M
from roboray.shared.mavlink.parser import Parser
from roboray.shared.mavlink.signing import Signing, key_from_passphrase

from test_mavlink_helpers import our_encode, random_fields

KEY = key_from_passphrase("sesame")


def test_key_is_sha256_of_the_passphrase_like_mavproxy():
    assert KEY == hashlib.sha256(b"sesame").digest() and len(KEY) == 32
    assert key_from_passphrase(b"sesame") == KEY


def _frame(ts: int, key: bytes = KEY, link: int = 2, seq: int = 0, sysid: int = 255) -> bytes:
    values = random_fields(M.MSG_COMMAND_LONG, random.Random(ts))
    return our_encode(M.MSG_COMMAND_LONG, values, seq, sysid, 190, key=key, link_id=link, timestamp=ts)


def _check(signing: Signing, frame: bytes) -> bool:
    p = Parser(signing)
    p.feed(frame)
    assert p.ready
    return p.sig_ok


def test_pymavlink_checks_our_signature_and_we_check_its():
    mav = pm.MAVLink(None, 255, 190)
    mav.signing.secret_key = KEY
    mav.signing.sign_outgoing = True
    mav.signing.link_id = 4
    mav.signing.timestamp = 5_000_000_000
    theirs = pm.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(mav)
    assert _check(Signing(KEY), theirs)
    rx = pm.MAVLink(None)
    rx.signing.secret_key = KEY
    rx.signing.timestamp = 0
    m = rx.parse_buffer(bytearray(_frame(5_000_000_000)))
    assert m and m[0].get_signed()


def test_wrong_key_and_tampered_frames_fail():
    s = Signing(KEY)
    assert not _check(s, _frame(100, key=key_from_passphrase("other")))
    f = bytearray(_frame(101))
    f[-1] ^= 0x01  # the signature itself
    assert not _check(s, bytes(f))
    f = bytearray(_frame(102))
    f[-8] ^= 0x01  # the timestamp: covered by the signature
    assert not _check(s, bytes(f))
    assert s.bad == 3 and s.good == 0


def test_replay_and_old_timestamps_are_refused_per_stream():
    s = Signing(KEY)
    first = _frame(10_000_000)
    assert _check(s, first)
    assert not _check(s, first)                     # the same frame again
    assert not _check(s, _frame(9_999_999))         # older on the same stream
    assert _check(s, _frame(10_000_001))
    assert _check(s, _frame(10_000_000, link=3))    # another link: its own stream
    assert _check(s, _frame(10_000_000, sysid=200))  # another system: its own stream
    assert s.replays == 2 and s.good == 4
    # our clock moved up to the newest good timestamp; a new stream far older is refused
    assert s.timestamp() == 10_000_001
    assert not _check(s, _frame(10_000_001 - 6_000_001, link=9))
    assert _check(s, _frame(10_000_001 - 5_999_000, link=10))


def test_timestamps_beyond_31_bits_stay_exact_and_carry():
    s = Signing(KEY, link_id=1)
    ts = (1 << 47) - 3
    s.hi, s.lo = ts >> 24, ts & 0xFFFFFF
    buf = bytearray(280)
    buf[0:3] = b"\xfd\x00\x01"
    for k in range(4):
        n = s.sign(buf, 12)
        assert n == 25
        assert int.from_bytes(buf[13:19], "little") == ts + 1 + k
    s.set_unix_time(1420070400 + 1.0)  # never moves the clock back
    assert s.timestamp() == ts + 4


def test_signing_on_micropython_matches_cpython(micropython):
    ts = 7_000_000_000
    micropython.exec(
        "from roboray.shared.mavlink.signing import Signing\n"
        "from roboray.shared.mavlink.parser import Parser\n"
        "__s = Signing(%r, 5)\n__s.hi = %d\n__s.lo = %d\n__b = bytearray(280)\n"
        "__b[0:12] = %r\n__n = __s.sign(__b, 12)\n" % (KEY, (ts - 1) >> 24, (ts - 1) & 0xFFFFFF,
                                                       b"\xfd\x00\x01\x00\x00\x01\x01\x00\x00\x00\x11\x22"))
    on_mp = micropython.eval("bytes(__b[:__n])")
    s = Signing(KEY, 5)
    s.hi, s.lo = (ts - 1) >> 24, (ts - 1) & 0xFFFFFF
    b = bytearray(280)
    b[0:12] = b"\xfd\x00\x01\x00\x00\x01\x01\x00\x00\x00\x11\x22"
    n = s.sign(b, 12)
    assert on_mp == bytes(b[:n]) and n == 25
    # and MicroPython verifies a pymavlink-signed frame
    frame = _frame(8_000_000_000)
    micropython.exec("__p = Parser(Signing(%r))\n__p.feed(%r)" % (KEY, frame))
    assert micropython.eval("[__p.ready, __p.signed, __p.sig_ok]") == [True, True, True]
