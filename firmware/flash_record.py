"""One small record on flash, replaced whole or not at all.

``FlashRecord(path, fs).load()`` returns the bytes last saved at ``path``
(or None), ``.save(data)`` replaces them. It is ``firmware/param_store.py``'s
scheme for any payload (the signing key and clock, the mission state): a
save writes ``path + '.tmp'``, reads it back and compares, moves the
current file aside to ``path + '.bak'`` and renames the temporary file into
place. A file counts only whole (magic, format, length and a SHA-256 over
everything before it agree), so a power cut at any step leaves the previous
record or the new one, never a mixture:

========================================  ===================================
cut during / after                        next ``load()`` returns
========================================  ===================================
opening, writing or checking ``.tmp``     main (previous record)
removing the old backup                   main (previous record)
renaming main to ``.bak``                 ``.tmp`` (new record, verified)
renaming ``.tmp`` to main                 main (new record)
========================================  ===================================

``load()`` tries main, then a whole ``.tmp`` (a save cut after its check:
it finishes that save with one rename), then ``.bak``; a leftover ``.tmp``
beside a good main file is removed. ``source`` says which it used
(``main``, ``tmp``, ``backup`` or ``none``) and ``problem`` why main was not
(or None). Renames never overwrite, so it works on FAT and LittleFS.

File format (little-endian): ``b"RRFR"``, format byte 1, payload length
(u16), payload, SHA-256 of all that (32 bytes). Payloads up to
``MAX_PAYLOAD`` bytes: a record is small, saved rarely (a save stalls the
chip, ``SAVE_STALL_MS``, announced first through ``expect_delay``); never
save one every step.

The file system is injected (``param_store.Files``, the board's, by default),
which is how the tests cut the power at every step.
"""

import hashlib

from roboray.firmware.param_store import Files, load_file, replace_file

_MAGIC = b"RRFR"
_FORMAT = 1
_HEAD = 7           # magic, format, length
_DIGEST = 32

#: The largest payload a record holds (bytes).
MAX_PAYLOAD = 4096

#: What a save stalls the Pico 2 for, at most in practice (the figure and
#: its reasons are ``param_store.SAVE_STALL_MS``'s: one sector erase, page
#: programs, littlefs metadata commits and now and then a compaction).
SAVE_STALL_MS = 150


def encode(data):
    """The file image of payload ``data``."""
    n = len(data)
    if n > MAX_PAYLOAD:
        raise ValueError("data: %d bytes, a record holds at most %d" % (n, MAX_PAYLOAD))
    body = bytearray(_MAGIC)
    body.append(_FORMAT)
    body.append(n & 0xFF)
    body.append(n >> 8)
    body.extend(data)
    body.extend(hashlib.sha256(body).digest())
    return bytes(body)


def decode(image):
    """``(payload, None)`` for a whole file, ``(None, reason)`` otherwise."""
    if image is None:
        return None, "missing"
    n = len(image)
    if n < _HEAD + _DIGEST:
        return None, "truncated (%d bytes)" % n
    if image[:4] != _MAGIC:
        return None, "not a record file"
    if image[4] != _FORMAT:
        return None, "format %d, expected %d" % (image[4], _FORMAT)
    length = image[5] | (image[6] << 8)
    if n != _HEAD + length + _DIGEST:
        return None, "length %d, file holds %d" % (length, n - _HEAD - _DIGEST)
    end = n - _DIGEST
    if hashlib.sha256(image[:end]).digest() != image[end:]:
        return None, "checksum mismatch"
    return bytes(image[_HEAD:end]), None


class FlashRecord:
    """The record at ``path`` on ``fs`` (``.tmp`` and ``.bak`` beside it).

    Attributes: ``source`` and ``problem`` (after ``load()``), ``saves``,
    and ``expect_delay`` (``expect_delay(ms)``, the scheduler's
    ``expect_delay_ms``: told before a save stalls the chip, or None).
    """

    def __init__(self, path, fs=None):
        self.path = path
        self.tmp = path + ".tmp"
        self.bak = path + ".bak"
        self.fs = fs if fs is not None else Files()
        self.source = "none"
        self.problem = None
        self.saves = 0
        self.expect_delay = None

    def load(self):
        """The payload last saved (bytes), or None when no whole record is there."""
        data, source, self.problem = load_file(self.fs, self.path, decode)
        self.source = source if source is not None else "none"
        return data

    def save(self, data):
        """Replace the record with ``data`` (bytes); raises OSError when flash fails."""
        image = encode(data)
        if self.expect_delay is not None:
            self.expect_delay(SAVE_STALL_MS)
        replace_file(self.fs, self.path, image, "record save")
        self.saves += 1
