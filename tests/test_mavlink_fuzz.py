"""100,000 fuzzed inputs through the parser (``roboray.sim.mavlink_fuzz``):
nothing raises, every good frame comes out, nothing damaged passes as good
(but a signature changed in place, without the key), and the counters add up.

Damage lands in signatures too: a signed frame whose signature is cut short
takes the next frame's first bytes as its own while its checksum passes.
The fuzz counts the good frames a parser lost and asserts each was
overlapped by a damaged frame's checked bytes (header, payload, checksum:
what no parser trusting checksums could have looked inside), with the key
and without. The inputs run as one stream in uneven chunks; the same
stream, a share of it, runs on MicroPython and must give the same frames,
signature verdicts and counters.
"""

from __future__ import annotations

import hashlib
import json
import random
import subprocess
import sys

import pytest

from roboray.shared.mavlink.parser import SIG_BAD, SIG_CUT, SIG_NONE, SIG_OK, SIG_UNCHECKED, Parser
from roboray.sim import mavlink_fuzz as F

from test_mavlink_helpers import MSGIDS, our_encode, random_fields

N_INPUTS = 100_000
MP_INPUTS = 4_000


def test_status_values_match_the_fuzz_accounting():
    assert (SIG_NONE, SIG_OK, SIG_UNCHECKED, SIG_BAD, SIG_CUT) == (
        F.UNSIGNED, F.SIG_OK, F.SIG_UNCHECKED, F.SIG_BAD, F.SIG_CUT)


@pytest.fixture()
def fuzz():
    fz = F.build(N_INPUTS)
    return fz, F.chunks(len(fz.data))


def _in_signature(d: F.Damaged) -> bool:
    """Damage that leaves header, payload and checksum whole: in a signed frame's last 13 bytes."""
    return d.signed and d.at >= d.full - F.SIG_LEN


def _common(fz: F.Fuzz, p: Parser, r: dict) -> None:
    assert r["good_frames"] == N_INPUTS * 5 // 4
    # good frames lost: only those a damaged frame's checked bytes covered
    assert r["good_lost"] == r["good_lost_overlapped"], r["lost_offsets"][:10]
    assert r["good_delivered"] + r["good_lost"] == r["good_frames"]
    assert r["good_flagged"] == 0
    # every frame built took a sequence number: the gaps are what never came out
    assert p.lost == fz.built - p.frames
    # a damaged frame that was delivered had its damage in the signature only
    assert p.frames == r["good_delivered"] + r["damaged_flagged"] + r["damaged_passed"]
    delivered_damaged = r["damaged_flagged"] + r["damaged_passed"]
    assert delivered_damaged == sum(_in_signature(d) for d in fz.damaged)
    rejected = [d for d in fz.damaged if not _in_signature(d)]
    assert p.crc_errors + p.bad_header + p.unknown >= sum(d.kind == "flip" for d in rejected)


def test_100k_fuzzed_inputs(fuzz):
    fz, bounds = fuzz
    # with the key
    p = Parser(F.receiver())
    r = F.account(fz, F.run(p, fz.data, bounds))
    _common(fz, p, r)
    assert r["good_lost"] == 0
    # the key flags every damaged signature, cut short or changed in place
    assert r["damaged_passed"] == 0
    assert p.bad_signature == r["damaged_flagged"] == sum(_in_signature(d) for d in fz.damaged)
    assert p.signing.good == sum(f[0] == 0xFD and f[2] & 1 for _, f in fz.good)
    # without
    p = Parser()
    r = F.account(fz, F.run(p, fz.data, bounds))
    _common(fz, p, r)
    assert r["good_lost"] == 0
    # a signature cut short is flagged (SIG_CUT) and the frame inside it delivered;
    # one changed in place cannot be told from a good one without the key
    cut = [d for d in fz.damaged if _in_signature(d) and d.kind == "cut"]
    assert r["damaged_cut_flagged_as_cut"] == r["damaged_flagged"] == len(cut) == p.cut_signature > 1000
    assert r["damaged_passed"] == r["damaged_passed_sig_flip"]
    assert p.bad_signature == 0


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


def _cut_signature_groups():
    """For each length a signature keeps (0-12 bytes): a signed frame cut
    there, a good frame, a good signed frame; their bytes, the frames and
    the verdicts (without the key, with it)."""
    rng = random.Random(5)
    seq = 0
    for keep in range(13):
        data = bytearray()
        want = []
        mid = MSGIDS[keep % len(MSGIDS)]
        signed = our_encode(mid, random_fields(mid, rng), seq, 1, 1, key=F.KEY, link_id=2,
                            timestamp=(F.CLOCK_HI << 24) + 100 + seq)
        nxt = our_encode(30, random_fields(30, rng), seq + 1, 1, 1)
        last = our_encode(0, random_fields(0, rng), seq + 2, 1, 1, key=F.KEY, link_id=2,
                          timestamp=(F.CLOCK_HI << 24) + 102 + seq)
        seq += 3
        cut = signed[:len(signed) - 13 + keep]
        data += cut + nxt + last
        want.append((bytes(cut + nxt)[:len(signed)], SIG_CUT, SIG_BAD))
        want.append((nxt, SIG_NONE, SIG_NONE))
        want.append((last, SIG_UNCHECKED, SIG_OK))
        yield keep, bytes(data), want


@pytest.mark.parametrize("keyed", [False, True], ids=["no key", "key"])
def test_cut_signatures_split_at_every_byte_boundary(keyed):
    for keep, data, want in _cut_signature_groups():
        expect = [(f, st_key if keyed else st) for f, st, st_key in want]
        for cut in range(len(data) + 1):
            p = Parser(F.receiver() if keyed else None)
            got = []
            for a, b in ((0, cut), (cut, len(data))):
                i = a
                while i < b:
                    i = p.feed(data, i, b)
                    if p.ready:
                        got.append((bytes(p.frame()), p.sig_status))
            assert got == expect, "signature cut to %d bytes, split at %d" % (keep, cut)
        # and a byte at a time
        p = Parser(F.receiver() if keyed else None)
        got = []
        for b in data:
            if p.parse_byte(b):
                got.append((bytes(p.frame()), p.sig_status))
        assert got == expect, "signature cut to %d bytes, byte by byte" % keep


_MP_RUN = """
from roboray.shared.mavlink.parser import Parser
from roboray.shared.mavlink.signing import Signing
import hashlib
def __fuzz(path, bounds, key, hi):
    data = open(path, 'rb').read()
    mv = memoryview(data)
    s = None
    if key is not None:
        s = Signing(key)
        s.hi = hi
    p = Parser(s)
    h = hashlib.sha256()
    k = 0
    for j in bounds:
        i = k
        while i < j:
            i = p.feed(mv, i, j)
            if p.ready:
                h.update(p.frame())
                h.update(bytes((p.sig_status,)))
        k = j
    return [h.digest(), p.frames, p.lost, p.crc_errors, p.bad_header, p.unknown, p.garbage,
            p.bad_signature, p.cut_signature]
"""


def test_fuzzed_share_on_micropython(micropython):
    fz = F.build(MP_INPUTS, seed=99)
    bounds = F.chunks(len(fz.data), seed=11)
    micropython.write_file("/tmp/fuzz.bin", fz.data)
    micropython.write_file("/tmp/fuzz_bounds.json", repr(bounds))
    micropython.exec(_MP_RUN)
    micropython.exec("import json\n__bounds = json.loads(open('/tmp/fuzz_bounds.json').read())")
    for key in (F.KEY, None):
        got = micropython.eval("__fuzz('/tmp/fuzz.bin', __bounds, %r, %d)" % (key, F.CLOCK_HI))
        # CPython on the same stream and chunks
        p = Parser(F.receiver() if key else None)
        out = F.run(p, fz.data, bounds)
        h = hashlib.sha256()
        for f, st in out:
            h.update(f)
            h.update(bytes((st,)))
        assert got[0] == h.digest()
        assert got[1:] == [p.frames, p.lost, p.crc_errors, p.bad_header, p.unknown, p.garbage,
                           p.bad_signature, p.cut_signature]
        r = F.account(fz, out)
        assert r["good_lost"] == 0 and r["good_delivered"] == len(fz.good)


def test_bench_mavlink_reports_the_frames_lost():
    from roboray.tools.micropython import rp2350_emu

    emu = rp2350_emu.available()
    proc = subprocess.run([sys.executable, "-m", "roboray.sim.cli", "bench", "mavlink", "--frames", "500",
                           "--repeat", "1", "--no-micropython", "--fuzz", "2000", "--json"]
                          + (["--rp2350"] if emu else []),
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    for key in ("encode_us", "parse_us_per_byte", "pymavlink_parse_us_per_byte", "parse_speed_ratio"):
        assert out[key] > 0, key
    assert out["fuzz_inputs"] == 2000 and out["fuzz_good_frames"] == 2500
    assert out["fuzz_good_frames_lost"] == out["fuzz_good_frames_lost_without_key"] == 0
    assert out["fuzz_damaged_passed"] == 0
    assert out["fuzz_damaged_flagged_without_key"] > 0
    if emu:   # counted on the emulated RP2350: a signed frame without the key costs no more than one with it
        for name in ("parse", "signed", "keyed"):
            assert out["rp2350_%s_insns_per_byte" % name] > 0
        assert out["rp2350_signed_us_per_frame"] < out["rp2350_keyed_us_per_frame"]
