"""The board code in the Pico 2's ROMFS partition (``mpremote romfs deploy``).

RoboRay's MicroPython for the Pico 2 (``roboray-flash firmware``) has a
read-only ROMFS partition in flash (256 kB; stock ``RPI_PICO2`` builds of
MicroPython 1.29 have none), mounted at ``/rom`` with ``/rom`` and ``/rom/lib``
before ``/lib`` on ``sys.path``. A ``.mpy`` imported from it runs in place:
its bytecode, constant strings and bytes stay in flash, off the heap, so the
firmware's live heap and every collection are smaller (``docs/design/
board-time.md``: 180 -> 106 kB live, 42.6 -> 31.2 ms a collection, before the
later reductions).

A ROMFS deployment:

1. builds the image of the build's ``/lib`` files (``mpremote.romfs.
   make_romfs``, the files already compiled: the image holds
   ``lib/roboray/...``, imported as ``/rom/lib/roboray/...``);
2. asks the board for its ROMFS partition (``vfs.rom_ioctl``); none, or too
   small: :class:`RomfsUnavailable` (``--target auto`` then deploys to
   ``/lib`` as before);
3. hashes the partition's first bytes on the board: the same image already
   there is not written again;
4. writes the image with mpremote's own ``romfs deploy`` over the same
   transport (erase, write in chunks), then hashes the partition on the
   board against the image (:class:`~.errors.HashMismatch` otherwise);
5. copies the files outside ``/lib`` (``main.py``) to the file system,
   verified, as the ``/lib`` deployment does, and restarts the board.

Files an earlier ``/lib`` deployment left under ``/lib/roboray`` stay (the
ROMFS comes first on ``sys.path``; ``lib_copy_on_board`` says so).
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import logging
import os
import tempfile
import time
from pathlib import Path

from . import manifest
from .board import Board
from .build import Build
from .deploy import finish
from .errors import FlashError, HashMismatch

log = logging.getLogger("roboray.flash")

#: The partition ``mpremote romfs deploy`` writes by default (a Pico 2 has one).
PARTITION = 0

#: Board folder whose files go into the image.
LIB = "/lib"

# MicroPython code run on the board: the partition's size (or why none) and
# the SHA-256 of its first n bytes.
_QUERY = """\
try:
    import vfs
    _rf_n = vfs.rom_ioctl(1) if hasattr(vfs, 'rom_ioctl') else -1
except ImportError:
    _rf_n = -1
if _rf_n <= %(part)d:
    print(json.dumps({'partitions': _rf_n}))
else:
    _rf_d = vfs.rom_ioctl(2, %(part)d)
    if hasattr(_rf_d, 'ioctl'):
        _rf_s = _rf_d.ioctl(4, 0) * _rf_d.ioctl(5, 0)
    else:
        _rf_s = len(_rf_d)
    print(json.dumps({'partitions': _rf_n, 'size': _rf_s}))
"""

_HASH = """\
import vfs
_rf_v = memoryview(vfs.rom_ioctl(2, %(part)d))
_rf_h = hashlib.sha256()
for _rf_o in range(0, %(n)d, 4096):
    _rf_h.update(_rf_v[_rf_o:min(%(n)d, _rf_o + 4096)])
print(binascii.hexlify(_rf_h.digest()).decode())
_rf_v = None
"""


class RomfsUnavailable(FlashError):
    """The board has no ROMFS partition, or one too small for the image."""


def lib_files(build: Build) -> list[str]:
    """The build's files that go into the image (everything under ``/lib``)."""
    return sorted(p for p in build.files if p.startswith(LIB + "/"))


def image(build: Build) -> bytes:
    """The ROMFS image of the build's ``/lib`` files, as ``mpremote romfs
    build`` makes it (``.mpy`` files stored as they are)."""
    from mpremote import romfs as mpremote_romfs

    with tempfile.TemporaryDirectory(prefix="roboray-romfs-") as d:
        for path in lib_files(build):
            dest = Path(d) / path.lstrip("/")
            dest.parent.mkdir(parents=True, exist_ok=True)
            data = build.data(path)
            if manifest.entry(data) != build.files[path]:
                raise HashMismatch("the build folder changed under the deployment (%s): build again" % path)
            dest.write_bytes(data)
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            img = mpremote_romfs.make_romfs(d, mpy_cross=False)
    return bytes(img)


def query(board: Board, partition: int = PARTITION) -> dict:
    """``{"partitions": n, "size": bytes}`` (no ``size`` without the partition)."""
    return board._json(_QUERY % {"part": partition}, "asking for its ROMFS partition")


def partition_sha(board: Board, n: int, partition: int = PARTITION) -> str:
    """SHA-256 (hex) of the partition's first ``n`` bytes, computed on the board."""
    return board.exec(_HASH % {"part": partition, "n": n}, "hashing its ROMFS partition").decode().strip()


class _State:
    """What mpremote's ``romfs deploy`` needs of its session: our transport,
    already at the raw REPL."""

    def __init__(self, transport) -> None:
        self.transport = transport

    def ensure_raw_repl(self, soft_reset=None) -> None:
        if not self.transport.in_raw_repl:
            self.transport.enter_raw_repl(soft_reset=soft_reset)

    def did_action(self) -> None:
        pass


def write(board: Board, img: bytes, partition: int = PARTITION) -> None:
    """Write ``img`` into the partition with mpremote's ``romfs deploy``."""
    from mpremote import commands
    from mpremote.transport import TransportError

    t = board._t
    if t is None:
        raise RomfsUnavailable("not connected to %s" % board.device)
    with tempfile.TemporaryDirectory(prefix="roboray-romfs-") as d:
        path = os.path.join(d, "board.romfs")
        with open(path, "wb") as f:
            f.write(img)
        out = io.StringIO()
        try:
            with contextlib.redirect_stdout(out):
                commands._do_romfs_deploy(_State(t), argparse.Namespace(path=path, partition=partition, mpy=False))
        except SystemExit:
            raise RomfsUnavailable("mpremote refused the ROMFS image: %s" % out.getvalue().strip().splitlines()[-1:])
        except commands.CommandError as exc:
            raise RomfsUnavailable("ROMFS deploy: %s" % exc) from None
        except TransportError as exc:
            board._t = t
            raise FlashError("the board failed while writing its ROMFS partition: %s" % exc) from None
        finally:
            text = out.getvalue().replace("\r", "\n").strip()
            if text:
                log.debug("mpremote romfs deploy: %s", " | ".join(x for x in text.splitlines() if x.strip()))


def deploy_romfs(board: Board, build: Build, reset: bool = True, start_timeout_s: float = 10.0,
                 dry_run: bool = False, partition: int = PARTITION) -> dict:
    """Bring the board to ``build`` with its ``/lib`` files in the ROMFS
    partition; the figures of what was done. Raises :class:`RomfsUnavailable`
    (nothing changed) when the board has no partition the image fits."""
    t0 = time.monotonic()
    img = image(build)
    sha = hashlib.sha256(img).hexdigest()
    q = query(board, partition)
    if not q.get("size"):  # the WebAssembly port reports one partition of 0 bytes
        # why, not what to do: --target auto goes on to /lib by itself, and
        # --target romfs adds the way out (cli.do_deploy)
        raise RomfsUnavailable("the board on %s has no ROMFS partition %d (a MicroPython built without "
                               "one, as stock RPI_PICO2 builds are; RoboRay's has one)" % (board.device, partition))
    if len(img) > q["size"]:
        raise RomfsUnavailable("the ROMFS image is %d bytes, the board's partition %d bytes" % (len(img), q["size"]))
    same = partition_sha(board, len(img), partition) == sha
    others = sorted(p for p in build.files if not p.startswith(LIB + "/"))
    survey = board.survey(manifest.BOARD_PATH, lib_files(build))
    on_fs = board.hashes(others)
    to_copy = [p for p in others if on_fs.get(p) != build.files[p]["sha256"]]
    lib_left = sorted(p for p in lib_files(build) if survey["sizes"].get(p, -1) >= 0)
    result: dict = {
        "port": board.device,
        "target": "romfs",
        "banner": build.banner,
        "dry_run": dry_run,
        "romfs_partition_bytes": q["size"],
        "romfs_image_bytes": len(img),
        "romfs_image_sha256": sha,
        "romfs_written": not same,
        "romfs_files": len(lib_files(build)),
        "files_copied": len(to_copy),
        "copied": to_copy,
        "files_removed": 0,
        "removed": [],
        "files_unchanged": len(others) - len(to_copy),
        "bytes_sent": 0,
        "bytes_to_send": (0 if same else len(img)) + sum(build.files[p]["size"] for p in to_copy),
        "lib_copy_on_board": len(lib_left),
        "verified": False,
    }
    if dry_run:
        result["seconds"] = time.monotonic() - t0
        return result
    sent = 0
    if not same:
        log.info("ROMFS: writing a %d-byte image to partition %d (%d bytes)", len(img), partition, q["size"])
        write(board, img, partition)
        sent += len(img)
        got = partition_sha(board, len(img), partition)
        if got != sha:
            raise HashMismatch("hash mismatch after writing the ROMFS partition: the board read back sha256 %s, "
                               "expected %s (deploy again)" % (got[:16], sha[:16]))
    for path in to_copy:
        data = build.data(path)
        board.put(path, data, build.files[path]["sha256"])
        sent += len(data)
    result["verified"] = True
    return finish(board, build, result, sent, t0, reset, start_timeout_s)
