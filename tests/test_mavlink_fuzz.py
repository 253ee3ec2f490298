"""100,000 fuzzed inputs through the parser: nothing raises, every valid frame
comes out, nothing damaged does, and the counters add up.

One sender numbers every frame it builds, valid or about to be damaged, so
the parser's ``lost`` count must equal the damaged and truncated frames
exactly. The inputs run as one stream in uneven chunks; a stretch of zeros
at the end flushes a false start byte still waiting for its claimed length.
The same stream, a share of it, runs on MicroPython and must give the same
frames and counters.
"""

from __future__ import annotations

import hashlib
import random
import struct

import pytest

from roboray.shared.mavlink import messages as M
from roboray.shared.mavlink.frame import Writer
from roboray.shared.mavlink.parser import Parser
from roboray.shared.mavlink.signing import Signing, key_from_passphrase

from test_mavlink_helpers import MSGIDS, flat, our_encode, random_fields

KEY = key_from_passphrase("fuzz")
N_INPUTS = 100_000
MP_INPUTS = 4_000


def build(n_inputs: int, seed: int = 2024):
    """(stream, valid frames in order, damaged count, counters expected)."""
    rng = random.Random(seed)
    pool = {mid: [flat(mid, random_fields(mid, rng)) for _ in range(4)] for mid in MSGIDS}
    plain, v1w = Writer(1, 1), Writer(1, 1, mavlink1=True)
    signing = Signing(KEY, 3)
    signing.hi = 1 << 16
    signed = Writer(1, 1, signing)
    seq = 0
    out = bytearray()
    valid: list[bytes] = []
    damaged = 0
    flipped = 0

    def frame(sign: bool = False) -> bytes:
        nonlocal seq
        mid = rng.choice(MSGIDS)
        w = signed if sign else (v1w if mid < 256 and rng.random() < 0.2 else plain)
        w.clear(M.TABLE[mid][M.MAX_LEN])
        struct.pack_into(M.TABLE[mid][M.FMT], w.buf, w.payload, *rng.choice(pool[mid]))
        n = w.finish(mid, seq & 0xFF)
        seq += 1
        return bytes(w.buf[:n])

    for k in range(n_inputs):
        kind = k % 4
        if kind == 0:  # random bytes, then a valid frame
            out += rng.randbytes(rng.randint(1, 40))
            f = frame()
            out += f
            valid.append(f)
        elif kind == 1:  # a frame with one flipped bit, then a valid frame
            bad = bytearray(frame())
            bit = rng.randrange(8, len(bad) * 8)  # not the start byte: it stays a candidate
            bad[bit // 8] ^= 1 << (bit % 8)
            out += bad
            damaged += 1
            flipped += 1
            f = frame()
            out += f
            valid.append(f)
        elif kind == 2:  # a truncated frame, then a valid frame
            bad = frame()
            # cut at least two bytes short: one byte short, the next start byte
            # would complete a valid checksum one time in 256 (a real frame then)
            out += bad[:rng.randrange(1, len(bad) - 1)]
            damaged += 1
            f = frame()
            out += f
            valid.append(f)
        else:  # two valid frames (one signed) split at one byte boundary
            pair = frame(sign=True) + frame()
            valid.append(pair[:pair[1] + 12 + 13])
            valid.append(pair[len(valid[-1]):])
            out += pair  # the chunking below splits the stream everywhere
    out += bytes(300)  # flush a false start byte waiting for its claimed length
    return bytes(out), valid, damaged, flipped


def chunks(n: int, seed: int = 7):
    """Uneven chunk boundaries, 1..97 bytes, so every offset gets split somewhere."""
    rng = random.Random(seed)
    i = 0
    while i < n:
        j = min(n, i + rng.randint(1, 97))
        yield i, j
        i = j


@pytest.fixture(scope="module")
def fuzz_stream():
    return build(N_INPUTS)


def run_cpython(stream: bytes):
    p = Parser(Signing(KEY))
    got = []
    sig = []
    for i, j in chunks(len(stream)):
        while i < j:
            i = p.feed(stream, i, j)
            if p.ready:
                got.append(bytes(p.frame()))
                if p.signed:
                    sig.append(p.sig_ok)
    return p, got, sig


def test_100k_fuzzed_inputs_on_cpython(fuzz_stream):
    stream, valid, damaged, flipped = fuzz_stream
    p, got, sig = run_cpython(stream)
    assert got == valid  # every valid frame, in order, and nothing else
    assert p.frames == len(valid)
    assert p.lost == damaged  # each damaged or truncated frame took a sequence number
    assert p.crc_errors + p.bad_header + p.unknown >= flipped  # each flipped frame was rejected
    assert sig and all(sig) and len(sig) == N_INPUTS // 4


def test_split_at_every_byte_boundary():
    rng = random.Random(3)
    frames = [our_encode(mid, random_fields(mid, rng), i, 1, 1) for i, mid in enumerate(MSGIDS)]
    data = b"".join(frames)
    for cut in range(len(data) + 1):
        p = Parser()
        got = []
        for a, b in ((0, cut), (cut, len(data))):
            i = a
            while i < b:
                i = p.feed(data, i, b)
                if p.ready:
                    got.append(bytes(p.frame()))
        assert got == frames, "split at %d" % cut


_MP_RUN = """
from roboray.shared.mavlink.frame import Writer
from roboray.shared.mavlink.parser import Parser
from roboray.shared.mavlink.signing import Signing
import hashlib
def __fuzz(path, bounds, key):
    data = open(path, 'rb').read()
    mv = memoryview(data)
    p = Parser(Signing(key))
    h = hashlib.sha256()
    nsig = 0
    allok = True
    k = 0
    for j in bounds:
        i = k
        while i < j:
            i = p.feed(mv, i, j)
            if p.ready:
                h.update(p.frame())
                if p.signed:
                    nsig += 1
                    allok = allok and p.sig_ok
        k = j
    return [h.digest(), p.frames, p.lost, p.crc_errors, p.bad_header, p.unknown, p.garbage, nsig, allok]
"""


def test_fuzzed_share_on_micropython(micropython):
    stream, valid, damaged, flipped = build(MP_INPUTS, seed=99)
    bounds = [j for _, j in chunks(len(stream), seed=11)]
    micropython.write_file("/tmp/fuzz.bin", stream)
    micropython.write_file("/tmp/fuzz_bounds.json", repr(bounds))
    micropython.exec(_MP_RUN)
    micropython.exec("import json\n__bounds = json.loads(open('/tmp/fuzz_bounds.json').read())")
    got = micropython.eval("__fuzz('/tmp/fuzz.bin', __bounds, %r)" % KEY)
    # CPython on the same stream and chunks
    p = Parser(Signing(KEY))
    h = hashlib.sha256()
    k = 0
    for j in bounds:
        i = k
        while i < j:
            i = p.feed(stream, i, j)
            if p.ready:
                h.update(p.frame())
        k = j
    assert got[0] == h.digest() == hashlib.sha256(b"".join(valid)).digest()
    assert got[1:7] == [p.frames, p.lost, p.crc_errors, p.bad_header, p.unknown, p.garbage]
    assert got[1] == len(valid) and got[2] == damaged
    assert got[7] == MP_INPUTS // 4 and got[8] is True
