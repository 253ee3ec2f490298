"""``roboray-flash``: build the board code and put it on a board.

- ``build``: compile ``shared/`` and ``firmware/`` for the RP2350 (:mod:`.build`);
- ``deploy``: bring a board to the build, verified: the board code into the
  Pico 2's ROMFS partition (:mod:`.romfs`) or, without one, to ``/lib``,
  safe to interrupt (:mod:`.deploy`);
- ``status``: what the board holds against the build;
- ``firmware``: the RoboRay MicroPython UF2 onto a Pico 2 (:mod:`.firmware`);
- ``virtual-board``: a MicroPython board on a pseudo-terminal, for trying all of it.
"""

from __future__ import annotations

import argparse
import hashlib
import logging
import os
import signal
import sys
import time
from pathlib import Path
from typing import Optional, Sequence

from roboray.tools.cli import CliError, UsageError, add_json, command, emit, make_parser, positive, run

log = logging.getLogger("roboray.flash")


def _build(args: argparse.Namespace):
    from .build import build

    return build(out_dir=args.out, source=args.source, src_root=args.src)


def do_build(args: argparse.Namespace) -> None:
    """Compile the board code into the build folder, incrementally."""
    result = _build(args)
    emit(args, result.summary(), lambda s: (
        "%s\n%d files, %d bytes in %s/board (%d compiled, %d unchanged, %d removed)"
        % (s["banner"], s["files"], s["bytes"], s["out"], s["compiled"], s["reused"], s["removed"])))


def _board(args: argparse.Namespace):
    from .board import Board
    from .ports import pick

    return Board(pick(args.port), timeout_s=args.timeout)


def do_deploy(args: argparse.Namespace) -> None:
    """Build if needed, then bring the board to the build."""
    from .deploy import deploy
    from .romfs import RomfsUnavailable, deploy_romfs

    # the board first: a port that is not there is said before anything
    # is built or written (the build folder included)
    from .firmware import build_note

    with _board(args) as board:
        board_build = board.identity()
        result = _build(args)
        report = None
        why = None
        if args.target in ("auto", "romfs"):
            try:
                report = deploy_romfs(board, result, dry_run=args.dry_run, reset=not args.no_reset,
                                      start_timeout_s=args.start_timeout)
            except RomfsUnavailable as exc:
                if args.target == "romfs":
                    raise RomfsUnavailable("%s; --target lib deploys to /lib instead" % exc) from None
                # said once, in the report ("no ROMFS: ...; deployed to /lib")
                why = str(exc)
        if report is None:
            report = deploy(board, result, dry_run=args.dry_run, rehash=args.rehash,
                            reset=not args.no_reset, start_timeout_s=args.start_timeout)
            report["target"] = "lib"
            if why:
                report["romfs_unavailable"] = why
    report["board_build"] = board_build
    report["firmware_note"] = build_note(board_build)
    emit(args, report, _deploy_text)


def _deploy_text(r: dict) -> str:
    if r.get("firmware_note"):
        return "note: %s\n%s" % (r["firmware_note"], _deploy_text(dict(r, firmware_note=None)))
    if r.get("target") == "romfs":
        img = "ROMFS image %d B of %d B partition %s" % (
            r["romfs_image_bytes"], r["romfs_partition_bytes"], "written" if r["romfs_written"] else "unchanged")
        if r["dry_run"]:
            lines = ["dry run on %s: %s, would copy %d file(s) to the file system; nothing changed"
                     % (r["port"], img.replace("written", "to write"), r["files_copied"])]
        else:
            lines = ["%s: %s (%d modules), copied %d file(s), all verified, %.1f s" % (
                r["port"], img, r["romfs_files"], r["files_copied"], r["seconds"])]
        if r["lib_copy_on_board"]:
            lines.append("note: %d file(s) of an earlier /lib deployment remain under /lib/roboray "
                         "(the ROMFS comes first on sys.path)" % r["lib_copy_on_board"])
        if "app_state" in r:
            lines.append("started: %s (%s)" % (r["banner"], r["app_state"]))
            lines += ["  | " + ln for ln in r["app_output"].splitlines()[1:]]
        return "\n".join(lines)
    if r.get("romfs_unavailable"):
        head = "no ROMFS: %s; deployed to /lib\n" % r["romfs_unavailable"]
        return head + _deploy_text(dict(r, romfs_unavailable=None))
    if r["dry_run"]:
        head = "dry run on %s: would copy %d file(s) (%d B), remove %d, keep %d; nothing changed" % (
            r["port"], r["files_copied"], r["bytes_to_send"], r["files_removed"], r["files_unchanged"])
        return "\n".join([head] + ["  copy   " + p for p in r["copied"]] + ["  remove " + p for p in r["removed"]])
    lines = ["%s: copied %d file(s) (%d B), removed %d, unchanged %d, all verified, %.1f s" % (
        r["port"], r["files_copied"], r["bytes_sent"], r["files_removed"], r["files_unchanged"], r["seconds"])]
    if "app_state" in r:
        lines.append("started: %s (%s)" % (r["banner"], r["app_state"]))
        lines += ["  | " + ln for ln in r["app_output"].splitlines()[1:]]
    return "\n".join(lines)


def do_status(args: argparse.Namespace) -> None:
    """Compare the board's files with the build (hashed on the board)."""
    from .deploy import status

    from .firmware import build_note

    result = _build(args)
    with _board(args) as board:
        report = status(board, result)
        report["board_build"] = board.identity()
    report["firmware_note"] = build_note(report["board_build"])
    emit(args, report, _status_text)


def _status_text(r: dict) -> str:
    b = r["board"]
    lines = [
        "board %s: %s" % (r["port"], b.get("banner") or b["manifest"])
        + ("" if b.get("complete", True) else " (last deployment did not finish)"),
        "build: %s (%d files)" % (r["build"]["banner"], r["build"]["files"]),
        "%d file(s) the same, %d differ, %d missing, %d to remove; %d kB free"
        % (r["same"], len(r["differ"]), len(r["missing"]), len(r["extra"]), r["free_bytes"] // 1024),
    ]
    lines += ["  differs  " + p for p in r["differ"]]
    lines += ["  missing  " + p for p in r["missing"]]
    lines += ["  extra    " + p for p in r["extra"]]
    lines.append("up to date" if r["up_to_date"] else "not up to date: roboray-flash deploy")
    if r.get("firmware_note"):
        lines.append("note: " + r["firmware_note"])
    return "\n".join(lines)


def do_firmware(args: argparse.Namespace) -> None:
    """Put the RoboRay MicroPython UF2 on a Pico 2 through its BOOTSEL drive."""
    from . import firmware as fw
    from .board import Board

    data, figures, expected = fw.load_image(args.uf2)
    report: dict = {"uf2": str(args.uf2 or fw.IMAGE), "uf2_bytes": len(data), "blocks": figures["blocks"],
                    "sha256": hashlib.sha256(data).hexdigest(), "expected": expected,
                    "bootloader_from": None}
    drive = args.drive
    if drive is not None:
        ready = lambda: drive if (drive / fw.INFO_FILE).is_file() else None  # noqa: E731
    else:
        drive = fw.find_drive()
        ready = fw.find_drive
    if drive is None or ready() is None:
        # No drive yet: a board running MicroPython on USB is told to become one.
        port = fw.micropython_port(args.port)
        if port is None:
            if args.drive is not None and not args.drive.is_dir():
                raise UsageError("--drive %s is not a folder (and no board on USB to restart into BOOTSEL)"
                                 % args.drive)
            if args.drive is None:
                raise fw.NoDrive("no Pico 2 BOOTSEL drive mounted (looked in %s) and no board on USB: hold "
                                 "BOOTSEL while plugging the Pico 2 in, or pass --drive"
                                 % ", ".join(str(r) for r in fw.mount_roots()))
        else:
            with Board(port, timeout_s=args.timeout) as board:
                report["board_before"] = before = board.identity()
                if fw.RP2350_BOARD_ID not in str(before.get("machine")):
                    raise fw.WrongBoard("the board on %s is a %s, not a Pico 2 (RP2350): this image is for the "
                                        "RP2350; nothing done" % (port, before.get("machine")))
                log.info("%s runs %s: restarting it into BOOTSEL", port, fw.describe_identity(before))
                board.bootloader()
            report["bootloader_from"] = port
            drive = fw.wait_for(ready, args.drive_timeout)
            if drive is None:
                raise fw.NoDrive("the board on %s was sent to BOOTSEL but no RP2350 drive was mounted %swithin %g s "
                                 "(mount it, then pass --drive)"
                                 % (port, "at %s " % args.drive if args.drive else "", args.drive_timeout))
    info = fw.check_drive(drive)
    report.update({"drive": str(drive), "board_id": info.get("Board-ID")})
    target = fw.write_image(drive, data)
    report["written"] = str(target)
    if not args.no_wait:
        port = fw.wait_for(lambda: fw.micropython_port(args.port), args.drive_timeout)
        if port is None:
            raise NoBoardFound("the image was written to %s but no board came back on USB within %g s "
                               "(replug it; a board still in BOOTSEL did not take the image)"
                               % (drive, args.drive_timeout))
        reported = fw.wait_for(lambda: _identity_or_none(port, args.timeout), args.timeout)
        if reported is None:
            raise fw.FirmwareMismatch("the board came back on %s but its MicroPython did not answer" % port)
        report.update({"port": port, "board": reported})
        why = fw.compare_identity(reported, expected)
        if why:
            raise fw.FirmwareMismatch("the board came back on %s running %s, not the image written: %s"
                                      % (port, fw.describe_identity(reported), why))
    emit(args, report, _firmware_text)


def _identity_or_none(port: str, timeout_s: float):
    from .board import Board
    from .errors import FlashError

    try:
        with Board(port, timeout_s=timeout_s) as board:
            return board.identity()
    except FlashError as exc:  # enumerated but not answering yet
        log.debug("%s: %s", port, exc)
        return None


def _firmware_text(r: dict) -> str:
    lines = []
    if r["bootloader_from"]:
        lines.append("%s was running %s: restarted it into BOOTSEL" % (r["bootloader_from"], _ident(r["board_before"])))
    lines.append("wrote %s (%d blocks, %d kB) to %s (Board-ID: %s)" % (
        os.path.basename(r["uf2"]), r["blocks"], r["uf2_bytes"] // 1024, r["drive"], r["board_id"]))
    if "board" in r:
        lines.append("%s is back: %s%s" % (r["port"], _ident(r["board"]),
                                           ", the build written" if r["expected"] else ""))
    return "\n".join(lines)


def _ident(ident: dict) -> str:
    from .firmware import describe_identity

    return describe_identity(ident)


def do_logs(args: argparse.Namespace) -> None:
    """Copy the board's flight logs (/logs/*.BIN) over USB; the ones already here, same size, are skipped."""
    from roboray.sim import progress

    out_dir = args.out
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise UsageError("--out %s is a file, not a folder" % out_dir)
    os.makedirs(out_dir, exist_ok=True)
    copied, skipped, nbytes = [], [], 0
    t0 = time.monotonic()
    with _board(args) as board:
        files = {n: s for n, s in board.listdir("/logs").items() if n.endswith(".BIN") and s >= 0}
        wanted = sorted(files)
        if args.numbers:
            names = {"%08d.BIN" % n for n in args.numbers}
            missing = sorted(names - set(files))
            if missing:
                raise CliError("not on the board: %s (it has %s)" % (", ".join(missing), ", ".join(wanted) or "no logs"))
            wanted = sorted(names)
        todo = [n for n in wanted if not (os.path.isfile(os.path.join(out_dir, n))
                                          and os.path.getsize(os.path.join(out_dir, n)) == files[n])]
        skipped = [n for n in wanted if n not in todo]
        with progress.bar(args, sum(files[n] for n in todo), "logs", unit="B") as bar:
            for name in todo:
                data = board.get("/logs/" + name, files[name], progress=bar.update)
                tmp = os.path.join(out_dir, name + ".part")
                with open(tmp, "wb") as f:
                    f.write(data)
                os.replace(tmp, os.path.join(out_dir, name))
                copied.append(name)
                nbytes += len(data)
    seconds = time.monotonic() - t0
    r = {"port": board.device, "folder": out_dir, "copied": copied, "skipped": skipped, "bytes": nbytes,
         "seconds": round(seconds, 2), "bytes_per_s": round(nbytes / seconds) if seconds > 0 else None}
    emit(args, r, lambda r: "%d log(s) copied to %s (%d bytes in %.1f s), %d already there"
         % (len(r["copied"]), r["folder"], r["bytes"], r["seconds"], len(r["skipped"])))


def do_virtual_board(args: argparse.Namespace) -> None:
    """Serve a MicroPython board on a pseudo-terminal until interrupted."""
    from roboray.tools.micropython.virtual_board import VirtualBoard, twin_builtins

    modules = [] if args.bare else args.module or twin_builtins()
    board = VirtualBoard(fs_dir=args.fs, flash_bytes=int(args.flash_kb * 1024), modules=modules).start()
    if modules:
        log.info("built-in modules: %s", ", ".join(str(m) for m in modules))
    # The device path is the first line, so scripts can read it and connect.
    sys.stdout.write(board.device + "\n")
    sys.stdout.flush()
    signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(KeyboardInterrupt()))
    try:
        status = board.wait()
    except KeyboardInterrupt:
        status = 0
    finally:
        board.close()
    if status not in (0, None):
        raise SystemExit("virtual board interpreter exited with status %d" % status)


def _build_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="build folder (default: build/flash in a checkout, else ~/.cache/roboray/flash-build)")
    p.add_argument("--source", action="store_true", help="copy .py files instead of compiling them with mpy-cross")
    p.add_argument("--src", type=Path, metavar="DIR",
                   help="take the board code from DIR/shared and DIR/firmware (default: this installation's)")


def _board_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--port", default="auto",
                   help="serial port of the board, or 'auto' to find a Pico 2 by its USB vendor id (default)")
    p.add_argument("--timeout", type=positive, default=10.0, metavar="S",
                   help="seconds the board may stay silent before it counts as not answering (default 10)")


def build_parser():
    parser, sub = make_parser("roboray-flash", "Build the RoboRay board code and deploy it to a board.")
    p = command(sub, "build", do_build, "compile the board code for the RP2350 and write its manifest")
    _build_options(p)
    add_json(p)

    p = command(sub, "deploy", do_deploy,
                "copy what differs to the board, verified and safe to interrupt, then restart it")
    _board_options(p)
    _build_options(p)
    p.add_argument("--target", choices=("auto", "romfs", "lib"), default="auto",
                   help="where the board code goes: the Pico 2's ROMFS partition (runs in place from flash, "
                        "off the heap), /lib on its file system, or auto: ROMFS when the board has it (default)")
    p.add_argument("--dry-run", action="store_true", help="say what would change, change nothing")
    p.add_argument("--rehash", action="store_true", help="trust no manifest: hash every file on the board")
    p.add_argument("--no-reset", action="store_true", help="leave the board at its REPL instead of restarting it")
    p.add_argument("--start-timeout", type=positive, default=10.0, metavar="S",
                   help="seconds to wait for the application's start-up line after the reset (default 10)")
    add_json(p)

    p = command(sub, "status", do_status, "compare the board's files with the build")
    _board_options(p)
    _build_options(p)
    add_json(p)

    p = command(sub, "firmware", do_firmware,
                "install the RoboRay MicroPython UF2 on a Pico 2 through its BOOTSEL drive")
    p.add_argument("--drive", type=Path, metavar="DIR",
                   help="the BOOTSEL drive's folder (default: the one mounted drive whose INFO_UF2.TXT says "
                        "Board-ID: RP2350; a board running MicroPython on USB is restarted into BOOTSEL first)")
    p.add_argument("--uf2", type=Path, metavar="FILE",
                   help="another UF2 to write (default: the RoboRay image, "
                        "tools/roboray_micropython/pico2/roboray-pico2.uf2)")
    p.add_argument("--no-wait", action="store_true",
                   help="stop after the copy: do not wait for the board to come back as MicroPython")
    p.add_argument("--port", default="auto",
                   help="serial port of a board running MicroPython to restart into BOOTSEL, and where to "
                        "find it back; 'auto' finds it by its USB vendor id (default)")
    p.add_argument("--drive-timeout", type=positive, default=30.0, metavar="S",
                   help="seconds to wait for the BOOTSEL drive, and for the board back on USB (default 30)")
    p.add_argument("--timeout", type=positive, default=10.0, metavar="S",
                   help="seconds the board may stay silent on USB before it counts as not answering (default 10)")
    add_json(p)

    p = command(sub, "logs", do_logs, "copy the board's flight logs (/logs/*.BIN) over USB, much faster than the radio")
    _board_options(p)
    p.add_argument("numbers", nargs="*", type=int, metavar="N", help="only these log numbers (default: all)")
    p.add_argument("--out", default="logs", metavar="DIR", help="folder to copy them into (default ./logs)")
    add_json(p)

    p = command(sub, "virtual-board", do_virtual_board,
                "serve a MicroPython board on a pseudo-terminal (prints its device path first)")
    p.add_argument("--fs", metavar="DIR", help="keep the board's file system in DIR (survives restarts)")
    p.add_argument("--flash-kb", type=positive, default=3072, metavar="KB",
                   help="flash size os.statvfs reports (default 3072, a Pico 2's)")
    p.add_argument("--module", action="append", metavar="FILE",
                   help="offer FILE (a .py) like a built-in module; repeatable (default: the twin's "
                        "emulated machine.py under sim/twin/, when it exists)")
    p.add_argument("--bare", action="store_true", help="offer no emulated built-in modules")
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    return run(build_parser(), argv)


if __name__ == "__main__":
    raise SystemExit(main())
