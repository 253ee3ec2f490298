"""Fuzzed MAVLink input for the board's parser, and what a parser made of it.

``build(n)`` makes ``n`` inputs as one stream, each fourth of one kind:

0. random bytes (1-40), then a good frame;
1. a frame with one bit flipped (not its start byte), then a good frame;
2. a frame cut short, then a good frame;
3. two good frames back to back, the first signed.

Good frames are MAVLink 2 (signed one time in four), or MAVLink 1 one time
in five of the unsigned; a frame about to be damaged is signed one time in
two, so damage lands in signatures too. The checksum covers header and
payload, not the 13 signature bytes: a bit flipped there, or a signature
cut short (the next frame's start byte and header then sit where the
parser reads signature bytes), leaves a frame whose checksum passes. A cut
is never one byte short of the checksum's end: the next start byte would
complete the checksum one time in 256 and make a valid frame of the
damaged one (a collision no parser can tell from a frame); nor is the first
byte cut off a start byte (the frame could then read whole, its last byte
the next frame's first).

One sender numbers every frame it builds, good or about to be damaged, so a
parser's ``lost`` counts the sequence numbers it never delivered.

``run(parser, data, bounds)`` feeds the stream in chunks and records what
came out; ``account`` sets that against the frames built: good frames
delivered, lost, damaged ones delivered flagged (``sig_status`` BAD or CUT)
or passed on as good. A good frame is *overlapped* when a damaged frame the
parser accepted covers its start byte with its header, payload or checksum
(the bytes the checksum vouches for): no parser trusting checksums finds it.
"""

from __future__ import annotations

import random
from bisect import bisect_left
from dataclasses import dataclass, field

from roboray.shared.mavlink import messages as M
from roboray.shared.mavlink.frame import Writer
from roboray.shared.mavlink.signing import Signing, key_from_passphrase

KEY = key_from_passphrase("fuzz")
SIG_LEN = 13
#: the sender's clock at the start (upper 24 bits of the 48-bit timestamp)
CLOCK_HI = 1 << 16

#: sig_status values (roboray.shared.mavlink.parser's SIG_*), for older parsers too
UNSIGNED, SIG_OK, SIG_UNCHECKED, SIG_BAD, SIG_CUT = 0, 1, 2, 3, 4


@dataclass
class Damaged:
    offset: int        # where its start byte is in the stream
    written: int       # bytes of it in the stream
    full: int          # its length before the damage
    signed: bool
    kind: str          # "flip" or "cut"
    at: int            # the flipped byte, or where the cut is


@dataclass
class Fuzz:
    data: bytes
    good: list[tuple[int, bytes]] = field(default_factory=list)   # (offset, frame), in order
    damaged: list[Damaged] = field(default_factory=list)
    built: int = 0     # frames built (sequence numbers used)
    inputs: int = 0


def build(n_inputs: int, seed: int = 2024) -> Fuzz:
    rng = random.Random(seed)
    table = M.TABLE
    ids = sorted(table)
    v1_ids = [m for m in ids if m < 256]
    plain, v1w = Writer(1, 1), Writer(1, 1, mavlink1=True)
    signing = Signing(KEY, 3)
    signing.hi = CLOCK_HI
    signed = Writer(1, 1, signing)
    seq = 0
    out = bytearray()
    fz = Fuzz(b"", inputs=n_inputs)

    def frame(sign: bool) -> bytes:
        nonlocal seq
        if sign:
            w = signed
        else:
            w = v1w if rng.random() < 0.2 else plain
        mid = rng.choice(v1_ids if w is v1w else ids)
        full = table[mid][3]   # MAX_LEN
        k = rng.randint(1, full) if rng.random() < 0.3 else full   # a zero tail MAVLink 2 truncates
        w.buf[w.payload:w.payload + full] = rng.randbytes(k) + bytes(full - k)
        n = w.finish(mid, seq & 0xFF)
        seq += 1
        return bytes(w.buf[:n])

    def good(sign: bool = False) -> None:
        f = frame(sign or rng.random() < 0.25)
        fz.good.append((len(out), f))
        out.extend(f)

    for k in range(n_inputs):
        kind = k % 4
        if kind == 0:
            out += rng.randbytes(rng.randint(1, 40))
            good()
        elif kind in (1, 2):
            sign = rng.random() < 0.5
            bad = bytearray(frame(sign))
            n = len(bad)
            if kind == 1:
                bit = rng.randrange(8, n * 8)   # not the start byte: it stays a candidate
                bad[bit // 8] ^= 1 << (bit % 8)
                at, kname = bit // 8, "flip"
            else:
                crc_end = n - SIG_LEN if sign else n
                while True:
                    at = rng.randrange(1, n)
                    if at != crc_end - 1 and bad[at] != 0xFD and bad[at] != 0xFE:
                        break
                bad = bad[:at]
                kname = "cut"
            fz.damaged.append(Damaged(len(out), len(bad), n, sign, kname, at))
            out += bad
            good()
        else:
            good(sign=True)
            good()
    out += bytes(300)   # flushes a false start byte waiting for its claimed length
    fz.data = bytes(out)
    fz.built = seq
    return fz


def receiver() -> Signing:
    """The receiving end's signing: the key, its clock where the sender's started."""
    s = Signing(KEY)
    s.hi = CLOCK_HI
    return s


def chunks(n: int, seed: int = 7):
    """Uneven chunk ends, 1..97 bytes apart, so every offset is split somewhere."""
    rng = random.Random(seed)
    out = []
    i = 0
    while i < n:
        i = min(n, i + rng.randint(1, 97))
        out.append(i)
    return out


def run(parser, data, bounds):
    """Feed ``data`` to ``parser`` ending chunks at ``bounds``; [(frame, sig_status)]."""
    got = []
    k = 0
    key = parser.signing is not None and parser.signing.key is not None
    for j in bounds:
        i = k
        while i < j:
            i = parser.feed(data, i, j)
            if parser.ready:
                st = getattr(parser, "sig_status", None)
                if st is None:   # a parser from before sig_status
                    st = UNSIGNED if not parser.signed else (
                        SIG_OK if parser.sig_ok else (SIG_BAD if key else SIG_UNCHECKED))
                got.append((bytes(parser.frame()), st))
        k = j
    return got


def _checked_len(f: bytes) -> int:
    """Header, payload and checksum of a frame: what its checksum vouches for."""
    if f[0] == 0xFD:
        return 10 + f[1] + 2
    return 6 + f[1] + 2


def account(fz: Fuzz, got) -> dict:
    """Good frames delivered and lost, damaged frames flagged and passed on."""
    data = fz.data
    good_at = dict(fz.good)
    damaged_at = {d.offset: d for d in fz.damaged}
    cursor = 0
    delivered_good = set()
    bogus = []          # (offset, checked length)
    r = {"good_frames": len(fz.good), "good_delivered": 0, "good_flagged": 0,
         "damaged_flagged": 0, "damaged_passed": 0, "damaged_passed_sig_flip": 0,
         "damaged_cut_flagged_as_cut": 0}
    for f, st in got:
        pos = data.find(f, cursor)
        if pos < 0:
            raise AssertionError("a delivered frame is not in the stream: %r" % f)
        cursor = pos + 1
        flagged = st == SIG_BAD or st == SIG_CUT
        if good_at.get(pos) == f:
            delivered_good.add(pos)
            r["good_delivered"] += 1
            r["good_flagged"] += flagged
            continue
        bogus.append((pos, _checked_len(f)))
        if flagged:
            r["damaged_flagged"] += 1
            d = damaged_at.get(pos)
            if st == SIG_CUT and d is not None and d.kind == "cut":
                r["damaged_cut_flagged_as_cut"] += 1
        else:
            r["damaged_passed"] += 1
            d = damaged_at.get(pos)
            # a signature changed in place (a bit flipped in its 13 bytes): no
            # receiver without the key can tell it from a good one
            if d is not None and d.signed and d.kind == "flip" and d.at >= d.full - SIG_LEN:
                r["damaged_passed_sig_flip"] += 1
    lost = [off for off, _ in fz.good if off not in delivered_good]
    starts = [b for b, _ in bogus]
    overlapped = 0
    for g in lost:
        j = bisect_left(starts, g) - 1
        while j >= 0 and starts[j] + 280 > g:
            b, c = bogus[j]
            if b < g < b + c:
                overlapped += 1
                break
            j -= 1
    r["good_lost"] = len(lost)
    r["good_lost_overlapped"] = overlapped
    r["lost_offsets"] = lost
    return r
