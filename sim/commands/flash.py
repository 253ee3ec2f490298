"""``roboray-sim bench flash``: roboray-flash deploy against ``mpremote fs cp -r``.

Both tools copy the same build (``roboray-flash build``'s ``board/`` folder)
to the same virtual board, in one run, each as the command a user types, so
the times include starting Python. Three cases for each:

- ``full``: an empty board (``mpremote fs cp -r lib main.py :`` against
  ``roboray-flash deploy --no-reset``);
- ``unchanged``: the same again (mpremote hashes every file on the board
  and skips the identical ones; roboray-flash trusts its manifest where the
  sizes agree, then verifies every hash);
- ``one_changed``: one module edited and rebuilt.

The board is wiped between the tools. The virtual board declines
raw-paste (the WebAssembly port mishandles it: ``tools/micropython/virtual_board.py``), so both tools send through the plain raw REPL, which
mpremote paces at 256 bytes every 10 ms: the figures rank the two tools,
a Pico 2 on USB (raw-paste) is faster with both.
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from roboray.sim import progress
from roboray.tools.cli import CliError, add_json, command, emit

_WIPE = """
import os
def _rm(p):
    for e in os.ilistdir(p):
        q = p + '/' + e[0]
        if e[1] == 0x4000:
            _rm(q)
            os.rmdir(q)
        else:
            os.remove(q)
for p in ('/lib', '/main.py'):
    try:
        if os.stat(p)[0] & 0x4000:
            _rm(p)
            os.rmdir(p)
        else:
            os.remove(p)
    except OSError:
        pass
"""

#: The module edited in the ``one_changed`` case.
EDITED = "shared/quat.py"


def _timed(cmd: list[str], cwd: Path | None = None) -> tuple[float, str]:
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=600)
    seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["no output"]
        raise CliError("%s failed: %s" % (" ".join(cmd[2:5]), tail[0]))
    return seconds, proc.stdout


def _wipe(device: str) -> None:
    from mpremote.transport_serial import SerialTransport

    t = SerialTransport(device, timeout=10)
    try:
        t.enter_raw_repl()
        t.exec(_WIPE)
        t.exit_raw_repl()
    finally:
        t.close()


def do_bench_flash(args: argparse.Namespace) -> None:
    from roboray.tools.flash.build import build, sources
    from roboray.tools.micropython.interpreter import BOARD_LIB
    from roboray.tools.micropython.virtual_board import VirtualBoard

    work = Path(tempfile.mkdtemp(prefix="roboray-bench-flash-"))
    try:
        # A private copy of the board code, so the edit touches nothing real.
        src = work / "src"
        for host, board_path in sources(args.src):
            dest = src / board_path[len(BOARD_LIB + "/roboray/"):]
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(host, dest)
        edited = src / EDITED
        original = edited.read_text()
        out = work / "out"
        b = build(out, source=args.source, src_root=src)

        mpremote = [sys.executable, "-m", "mpremote"]
        flash = [sys.executable, "-m", "roboray.tools.flash.cli", "deploy", "--out", str(out),
                 "--src", str(src), "--no-reset", "--json"] + (["--source"] if args.source else [])
        runs: dict[str, dict[str, list[float]]] = {}
        sent: dict[str, int] = {}

        def record(case: str, tool: str, seconds: float) -> None:
            runs.setdefault(case, {}).setdefault(tool, []).append(seconds)

        def rebuild(text: str) -> None:
            edited.write_text(text)
            build(out, source=args.source, src_root=src)

        with VirtualBoard(fs_dir=work / "fs") as vb, \
                progress.bar(args, 6 * args.repeat, "bench flash", "copies") as bar:
            cp = mpremote + ["connect", vb.device, "fs", "cp", "-r", "lib", "main.py", ":"]
            dep = flash + ["--port", vb.device]

            def timed(cmd: list[str], tool: str, case: str, cwd: Path | None = None) -> tuple[float, str]:
                bar.set_postfix_str("%s, %s" % (tool, case))
                out = _timed(cmd, cwd=cwd)
                bar.update(1)
                return out

            for _ in range(args.repeat):
                _wipe(vb.device)
                record("full", "mpremote", timed(cp, "mpremote", "full", cwd=b.board_dir)[0])
                record("unchanged", "mpremote", timed(cp, "mpremote", "unchanged", cwd=b.board_dir)[0])
                rebuild(original + "\n_BENCH_EDIT = 1\n")
                record("one_changed", "mpremote", timed(cp, "mpremote", "one changed", cwd=b.board_dir)[0])
                rebuild(original)

                _wipe(vb.device)
                for case in ("full", "unchanged"):
                    seconds, text = timed(dep, "roboray-flash", case)
                    record(case, "roboray_flash", seconds)
                    sent[case] = json.loads(text)["bytes_sent"]
                rebuild(original + "\n_BENCH_EDIT = 1\n")
                seconds, text = timed(dep, "roboray-flash", "one changed")
                record("one_changed", "roboray_flash", seconds)
                sent["one_changed"] = json.loads(text)["bytes_sent"]
                rebuild(original)
    finally:
        shutil.rmtree(work, ignore_errors=True)

    result: dict = {
        "files": len(b.files),
        "build_bytes": sum(e["size"] for e in b.files.values()),
        "compiler": b.manifest["compiler"],
        "repeat": args.repeat,
        "board": "virtual (MicroPython %s WebAssembly behind a pty, plain raw REPL)" % _mp_version(),
    }
    for case, tools in runs.items():
        mp_s = statistics.median(tools["mpremote"])
        rf_s = statistics.median(tools["roboray_flash"])
        result[case] = {
            "mpremote_s": round(mp_s, 3),
            "roboray_flash_s": round(rf_s, 3),
            "speedup": round(mp_s / rf_s, 2),
            "roboray_flash_bytes_sent": sent[case],
        }
    result["roboray_flash_at_least_as_fast"] = all(result[c]["speedup"] >= 1.0 for c in runs)
    emit(args, result, _text)


def _mp_version() -> str:
    from roboray.tools.micropython.install import VERSION

    return VERSION


def _text(r: dict) -> str:
    lines = ["%d files, %d bytes (%s), median of %d" % (r["files"], r["build_bytes"], r["compiler"], r["repeat"]),
             "%-12s %12s %15s %8s %12s" % ("case", "mpremote s", "roboray-flash s", "speedup", "bytes sent")]
    for case in ("full", "unchanged", "one_changed"):
        c = r[case]
        lines.append("%-12s %12.2f %15.2f %7.1fx %12d" % (case, c["mpremote_s"], c["roboray_flash_s"],
                                                         c["speedup"], c["roboray_flash_bytes_sent"]))
    return "\n".join(lines)


def register(sub, bench) -> None:
    p = command(bench, "flash", do_bench_flash,
                "roboray-flash deploy against mpremote fs cp -r, same files, same virtual board")
    p.add_argument("--repeat", type=int, default=1, choices=range(1, 11), metavar="N",
                   help="runs of each case; the median is reported (default 1)")
    p.add_argument("--source", action="store_true", help="copy .py files instead of .mpy")
    p.add_argument("--src", type=Path, metavar="DIR", help="board code from DIR/shared and DIR/firmware")
    add_json(p)
