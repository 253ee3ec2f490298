"""``roboray-flash firmware``: the RoboRay MicroPython UF2 onto a Pico 2.

A Pico 2 held in BOOTSEL (or told ``machine.bootloader()``) shows its boot
ROM as a small FAT drive whose ``INFO_UF2.TXT`` names the chip
(``Board-ID: RP2350``; an RP2040's says ``RPI-RP2``). Copying a UF2 onto
it flashes the image; once the last block is in, the ROM restarts the board
into it (RP2350 datasheet, section 5.5). So installing is:

1. the drive: ``--drive``, or the one mounted drive with an
   ``INFO_UF2.TXT`` among the usual mount points (:data:`MOUNT_ROOTS`);
   when there is none and a board runs MicroPython on USB
   (:mod:`.ports`), that board is told ``machine.bootloader()`` over the
   raw REPL, as ``mpremote bootloader`` does, and the drive is waited for;
2. refusal of any other chip's drive, with one line, before anything is
   written;
3. the UF2 checked (:mod:`.uf2`: family, block numbers, flash addresses,
   the IMAGE_DEF the boot ROM needs), then written in one piece and synced
   under its final name (a FAT drive offers no atomic rename, and the boot
   ROM takes blocks as they arrive whatever the file is called; it starts
   the image only once every block is in, so a copy cut short leaves the
   board in BOOTSEL, never running half an image);
4. unless ``--no-wait``: the board waited for on USB as MicroPython and the
   build it reports (``os.uname()``, ``sys.implementation._build``)
   compared with the image's identity (``roboray-pico2.json``).

The image is ``tools/roboray_micropython/pico2/roboray-pico2.uf2``, built
by ``build.sh`` there from pinned sources; ``BUILD.txt`` says how.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import sys
import time
from pathlib import Path
from typing import Callable, Iterable, Optional

from . import uf2
from .errors import FlashError, NoBoardFound

log = logging.getLogger("roboray.flash")

#: The RoboRay image, its checksum and identity, as build.sh writes them.
IMAGE_DIR = Path(__file__).resolve().parent.parent / "roboray_micropython" / "pico2"
IMAGE = IMAGE_DIR / "roboray-pico2.uf2"
IDENTITY = IMAGE_DIR / "roboray-pico2.json"

#: The file the boot ROM's drive describes itself in.
INFO_FILE = "INFO_UF2.TXT"
#: What an RP2350's boot ROM writes after ``Board-ID:``.
RP2350_BOARD_ID = "RP2350"
#: Name the image is written under on the drive (any name flashes).
TARGET_NAME = "ROBORAY.UF2"


class WrongBoard(FlashError):
    """The BOOTSEL drive belongs to another chip; nothing was written."""


class NoDrive(FlashError):
    """No RP2350 BOOTSEL drive appeared."""


class FirmwareMismatch(FlashError):
    """The board came back running another build than the one written."""


def mount_roots() -> list[Path]:
    """Folders whose subfolders are mounted drives, on this system."""
    if sys.platform == "darwin":
        return [Path("/Volumes")]
    if sys.platform == "win32":
        return []
    user = os.environ.get("USER") or os.environ.get("LOGNAME") or ""
    roots = [Path("/media") / user, Path("/run/media") / user] if user else []
    return roots + [Path("/media"), Path("/mnt")]


def candidate_drives(roots: Optional[Iterable[Path]] = None) -> list[Path]:
    """Mounted drives that hold an ``INFO_UF2.TXT`` (any chip's), sorted."""
    found = set()
    if roots is None and sys.platform == "win32":
        found.update(Path("%s:\\" % c) for c in "DEFGHIJKLMNOPQRSTUVWXYZ"
                     if os.path.isfile("%s:\\%s" % (c, INFO_FILE)))
    for root in mount_roots() if roots is None else roots:
        try:
            entries = list(Path(root).iterdir())
        except OSError:
            continue
        found.update(e for e in entries if (e / INFO_FILE).is_file())
    return sorted(found)


def read_info(drive: Path) -> dict[str, str]:
    """``INFO_UF2.TXT``'s ``Key: value`` lines."""
    try:
        text = (Path(drive) / INFO_FILE).read_text(errors="replace")
    except FileNotFoundError:
        raise NoDrive("%s is not a BOOTSEL drive: it has no %s" % (drive, INFO_FILE)) from None
    except OSError as exc:
        raise NoDrive("cannot read %s on %s: %s" % (INFO_FILE, drive, exc.strerror or exc)) from None
    info = {}
    for line in text.splitlines():
        key, sep, value = line.partition(":")
        if sep:
            info[key.strip()] = value.strip()
    return info


def check_drive(drive: Path) -> dict[str, str]:
    """The drive's info if it is an RP2350's BOOTSEL drive; :class:`WrongBoard` if not."""
    info = read_info(drive)
    board_id = info.get("Board-ID")
    if board_id is None:
        raise WrongBoard("%s: its %s names no Board-ID; not a Raspberry Pi boot ROM's drive, nothing written"
                         % (drive, INFO_FILE))
    if board_id.split("-")[0] != RP2350_BOARD_ID:
        chip = "an RP2040's (a Pico or Pico W)" if board_id == "RPI-RP2" else "another chip's"
        raise WrongBoard("%s is %s BOOTSEL drive (Board-ID: %s), not a Pico 2's (RP2350): "
                         "this image is for the RP2350; nothing written" % (drive, chip, board_id))
    return info


def load_image(path: Optional[Path] = None) -> tuple[bytes, dict, Optional[dict]]:
    """(UF2 bytes, :func:`uf2.check` figures, the identity it should report or None).

    The identity is known for the RoboRay image (its sha256 checked against
    ``roboray-pico2.json``) or for a UF2 with a ``.json`` of that form beside it.
    """
    path = Path(path) if path is not None else IMAGE
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise FlashError("no UF2 at %s" % path) from None
    except OSError as exc:
        raise FlashError("cannot read %s: %s" % (path, exc.strerror or exc)) from None
    try:
        figures = uf2.check(data)
    except uf2.Uf2Error as exc:
        raise FlashError("%s is not an image a Pico 2 would start: %s; nothing written" % (path.name, exc)) from None
    identity = None
    side = path.with_suffix(".json")
    if side.is_file():
        identity = json.loads(side.read_text())
        if identity.get("sha256") != hashlib.sha256(data).hexdigest():
            raise FlashError("%s does not match its checksum in %s (damaged or replaced); nothing written"
                             % (path.name, side.name))
    return data, figures, identity


def write_image(drive: Path, data: bytes) -> Path:
    """Write the UF2 onto the drive in one piece, flushed to it; the file written."""
    target = Path(drive) / TARGET_NAME
    written = 0
    try:
        with open(target, "wb") as f:
            written = f.write(data)
            f.flush()
            os.fsync(f.fileno())
    except OSError as exc:
        if written == len(data):
            # The boot ROM restarts the board once the last block is in:
            # the drive may vanish before the file is closed.
            log.debug("drive went away after the last block: %s", exc)
            return target
        raise FlashError("copying to %s failed: %s; the board stays in BOOTSEL: run the command again"
                         % (drive, exc.strerror or exc)) from None
    return target


def find_drive(roots: Optional[Iterable[Path]] = None) -> Optional[Path]:
    """The one RP2350 BOOTSEL drive mounted, None if there is none; refuses
    another chip's drive when it is the only one."""
    drives = candidate_drives(roots)
    rp2350 = [d for d in drives if read_info(d).get("Board-ID", "").split("-")[0] == RP2350_BOARD_ID]
    if len(rp2350) > 1:
        raise NoDrive("%d Pico 2 BOOTSEL drives mounted (%s): choose one with --drive"
                      % (len(rp2350), ", ".join(str(d) for d in rp2350)))
    if rp2350:
        return rp2350[0]
    if drives:
        check_drive(drives[0])  # says which chip it is
    return None


def wait_for(probe: Callable[[], Optional[object]], timeout_s: float, poll_s: float = 0.25):
    """``probe()``'s first answer that is not None within ``timeout_s``, else None."""
    deadline = time.monotonic() + timeout_s
    while True:
        found = probe()
        if found is not None:
            return found
        if time.monotonic() >= deadline:
            return None
        time.sleep(poll_s)


def micropython_port(port: str = "auto", ports=None) -> Optional[str]:
    """The board's serial port (``port``, or the one ``auto`` finds on USB),
    None while it is not there."""
    from .ports import pick

    if port != "auto":
        return port if "://" in port or os.path.exists(port) else None
    try:
        return pick("auto", ports)
    except NoBoardFound as exc:
        if "boards found" in str(exc):
            raise
        return None


def compare_identity(reported: dict, expected: Optional[dict]) -> Optional[str]:
    """Why the board's build is not ``expected`` (None when it is, or nothing is expected)."""
    if expected is None:
        return None
    for key, what in (("build", "sys.implementation._build"), ("machine", "os.uname().machine"),
                      ("version", "os.uname().version")):
        if reported.get(key) != expected.get(key):
            return "%s is %r, the image's is %r" % (what, reported.get(key), expected.get(key))
    return None


def describe_identity(ident: dict) -> str:
    """One phrase naming a build: ``MicroPython <version>, <machine> (<build>)``."""
    return "MicroPython %s, %s (%s)" % (ident.get("version"), ident.get("machine"), ident.get("build"))


def expected_identity() -> Optional[dict]:
    """The identity of the RoboRay image this installation carries, None without one."""
    try:
        return json.loads(IDENTITY.read_text())
    except (OSError, ValueError):
        return None


def build_note(reported: dict, expected: Optional[dict] = None) -> Optional[str]:
    """One line when the board's MicroPython is not the RoboRay build the
    firmware expects (None when it is): what it runs, and the command that
    installs the right one. Stock MicroPython still flies, with floats on
    the heap and collections in flight, so this is a note, not a refusal."""
    expected = expected if expected is not None else expected_identity()
    if expected is None or compare_identity(reported, expected) is None:
        return None
    return ("the board runs %s, not the RoboRay MicroPython this firmware expects (%s, %s: floats off the heap, "
            "no collection in flight): install it with `roboray-flash firmware`"
            % (describe_identity(reported), expected["version"], expected["build"]))
