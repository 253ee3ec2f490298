"""The manifest: which files a build holds, and which files a board holds of ours.

A build writes ``manifest.json`` beside its files; a deployment writes the
same document to the board (:data:`BOARD_PATH`) as its last step, with
``"complete": true``. Before it changes any file on the board it writes a
copy with ``"complete": false`` listing the files of the old and the new
build, so a deployment cut short leaves a manifest that (1) says its hashes
are not to be trusted and (2) still names every file the tool may remove.

Document (JSON, keys sorted, compact, so an unchanged build gives the same
bytes)::

    {"format": 1, "project": "roboray", "version": "0.1.0",
     "revision": "<40 hex>" | "unknown", "dirty": true | false | null,
     "banner": "RoboRay firmware 0.1.0 ba4ae25be6f8-dirty",
     "compiler": "mpy-cross 1.29.0 -march=armv7emsp" | "source",
     "mpy_version": "6.3" | null,
     "files": {"/lib/roboray/shared/quat.mpy": {"size": 2345, "sha256": "<64 hex>"}, ...},
     "complete": true}                               (board copy only)
"""

from __future__ import annotations

import hashlib
import json
from typing import Any, Optional

FORMAT = 1

#: Where a deployment keeps the manifest on the board.
BOARD_PATH = "/lib/roboray/manifest.json"

_HEX = frozenset("0123456789abcdef")


def entry(data: bytes) -> dict:
    """Manifest entry of one file's content."""
    return {"size": len(data), "sha256": hashlib.sha256(data).hexdigest()}


def encode(manifest: dict) -> bytes:
    """Canonical bytes of a manifest: the same document gives the same bytes."""
    return (json.dumps(manifest, sort_keys=True, separators=(",", ":")) + "\n").encode()


def decode(text: Optional[str | bytes]) -> tuple[Optional[dict], str]:
    """A manifest read from a board, checked; ``(None, why)`` when unusable.

    A board's manifest may be missing, cut short or written by something
    else; none of that is an error, it only means the board's files must be
    hashed and that no file may be removed on its word.
    """
    if text is None:
        return None, "no manifest on the board"
    try:
        doc: Any = json.loads(text)
    except ValueError:
        return None, "the board's manifest is not valid JSON"
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        return None, "the board's manifest has an unknown format"
    files = doc.get("files")
    if not isinstance(files, dict):
        return None, "the board's manifest lists no files"
    for path, e in files.items():
        ok = (
            isinstance(path, str) and path.startswith("/") and isinstance(e, dict)
            and isinstance(e.get("size"), int) and _is_sha256(e.get("sha256"))
        )
        if not ok:
            return None, "the board's manifest has a malformed entry for %r" % (path,)
    return doc, ""


def _is_sha256(value: Any) -> bool:
    return isinstance(value, str) and len(value) == 64 and set(value) <= _HEX
