"""Shared by the MAVLink tests: random messages, and both codecs side by side."""

from __future__ import annotations

import inspect
import random
import struct
from typing import Any

from pymavlink.dialects.v20 import development as pm  # common.xml and the standard modes

from roboray.shared.mavlink import messages as M
from roboray.shared.mavlink.frame import Writer
from roboray.shared.mavlink.signing import Signing

MSGIDS = sorted(M.TABLE)

_INT_RANGES = {
    "B": (0, 255), "b": (-128, 127), "H": (0, 65535), "h": (-32768, 32767),
    "I": (0, 2**32 - 1), "i": (-2**31, 2**31 - 1), "Q": (0, 2**64 - 1), "q": (-2**63, 2**63 - 1),
}


def _codes(fmt: str) -> list[tuple[int, str]]:
    """'<I4fB10s' -> [(1, 'I'), (4, 'f'), (1, 'B'), (10, 's')]."""
    out, num = [], ""
    for ch in fmt[1:]:
        if ch.isdigit():
            num += ch
        else:
            out.append((int(num) if num else 1, ch))
            num = ""
    return out


def random_fields(msgid: int, rng: random.Random, zero_tail: bool = False) -> dict[str, Any]:
    """Random values for every field of a message, by name, as pymavlink takes them."""
    entry = M.TABLE[msgid]
    values: dict[str, Any] = {}
    for name, (count, code) in zip(entry[M.FIELDS], _codes(entry[M.FMT])):
        def one() -> Any:
            if code in _INT_RANGES:
                lo, hi = _INT_RANGES[code]
                return rng.randint(lo, hi) if rng.random() < 0.8 else rng.choice((0, lo, hi))
            if code == "f":
                x = rng.uniform(-1e4, 1e4) if rng.random() < 0.9 else 0.0
                return struct.unpack("<f", struct.pack("<f", x))[0]
            if code == "d":
                return rng.uniform(-1e9, 1e9)
            raise AssertionError(code)
        if code == "s":
            n = rng.randint(0, count)
            values[name] = bytes(rng.choice(b"ABCDEFGHIJKLMNOPQRSTUVWXYZ_0123456789") for _ in range(n))
        elif count > 1:
            values[name] = [one() for _ in range(count)]
        else:
            values[name] = one()
    if msgid == M.MSG_HEARTBEAT:
        values["mavlink_version"] = 3  # pymavlink always sends 3
    return values


def flat(msgid: int, values: dict[str, Any]) -> list[Any]:
    """Values in wire order, arrays spread, as struct.pack_into takes them."""
    out: list[Any] = []
    for name in M.TABLE[msgid][M.FIELDS]:
        v = values[name]
        out.extend(v if isinstance(v, list) else [v])
    return out


def pymavlink_message(msgid: int, values: dict[str, Any]) -> Any:
    cls = pm.mavlink_map[msgid]
    params = inspect.signature(cls.__init__).parameters
    return cls(**{k: v for k, v in values.items() if k in params})


def pymavlink_encode(msgid: int, values: dict[str, Any], seq: int, sysid: int, compid: int,
                     mavlink1: bool = False, key: bytes | None = None, link_id: int = 0,
                     timestamp: int = 0) -> bytes:
    mav = pm.MAVLink(None, sysid, compid)
    mav.seq = seq
    if key is not None:
        mav.signing.secret_key = key
        mav.signing.sign_outgoing = True
        mav.signing.link_id = link_id
        mav.signing.timestamp = timestamp
    return bytes(pymavlink_message(msgid, values).pack(mav, force_mavlink1=mavlink1))


def our_encode(msgid: int, values: dict[str, Any], seq: int, sysid: int, compid: int,
               mavlink1: bool = False, key: bytes | None = None, link_id: int = 0,
               timestamp: int = 0) -> bytes:
    signing = None
    if key is not None:
        signing = Signing(key, link_id)
        ts = timestamp - 1  # sign() takes the next timestamp, pymavlink the current one
        signing.hi, signing.lo = ts >> 24, ts & 0xFFFFFF
    w = Writer(sysid, compid, signing, mavlink1)
    w.clear(M.TABLE[msgid][M.MAX_LEN])
    struct.pack_into(M.TABLE[msgid][M.FMT], w.buf, w.payload, *flat(msgid, values))
    n = w.finish(msgid, seq)
    return bytes(w.buf[:n])


def pymavlink_decode(frame: bytes, key: bytes | None = None) -> Any:
    mav = pm.MAVLink(None)
    if key is not None:
        mav.signing.secret_key = key
    msgs = mav.parse_buffer(bytearray(frame))
    assert msgs and len(msgs) == 1, "pymavlink did not decode %r" % frame
    return msgs[0]


def same_value(a: Any, b: Any) -> bool:
    if isinstance(a, list) or isinstance(b, list):
        return list(a) == list(b)
    if isinstance(a, bytes):
        a = a.decode()
    if isinstance(b, bytes):
        b = b.decode()
    return a == b


def test_format_codes_cover_every_field():
    # the helper's reading of a struct format must line up with the field names
    for msgid in MSGIDS:
        entry = M.TABLE[msgid]
        codes = _codes(entry[M.FMT])
        assert len(codes) == len(entry[M.FIELDS])
        assert [c if c > 1 and code != "s" else 0 for c, code in codes] == list(entry[M.ARRAYS])
