"""The parameter table on flash, safe against a power cut at any moment.

A save writes the whole set to a temporary file, reads it back and compares,
then moves the current file aside as the backup and renames the temporary
file into place. A file is accepted only whole: magic, format, length and a
SHA-256 over everything before it must agree. So a power cut at any point of
a save leaves the previous set or the new one, never a mixture:

========================================  ===================================
cut during / after                        next boot loads
========================================  ===================================
writing or checking ``.tmp``              main (previous set)
removing the old backup                   main (previous set)
renaming main to ``.bak``                 ``.tmp`` (new set, verified)
renaming ``.tmp`` to main                 main (new set)
========================================  ===================================

At boot ``load()`` tries the main file, then a complete ``.tmp`` (a save cut
short after its check: it finishes that save), then ``.bak``, then keeps
the defaults, and says which in ``source`` and ``problem``. A leftover
``.tmp`` beside a good main file is an unfinished save's and is removed.

Renames never overwrite (the old target is removed or moved first), so the
scheme works on FAT as well as on LittleFS, the rp2 default.

File format (little-endian): ``b"RRPS"``, format byte 1, entry count (u16),
then per entry: name length (u8), name (ASCII), kind (``f``: float32,
``i``: int32), value (4 bytes); then the SHA-256 of all that (32 bytes).
Entries are matched by name, so a firmware that adds or drops parameters
still loads the rest; unknown names and values the table refuses are
counted (``unknown``, ``rejected``), not fatal.

The table is used through the ``shared/params.py`` API: ``count()``,
``name(i)``, ``type(i)``, ``get(i)``, ``set(i, value) -> error code``,
``index(name)``, and ``flags(i)`` and ``version`` when it has them (read-only
parameters are not saved; ``version`` tells ``service()`` a save is due).
The file system is injected (``Files`` by default), which is how the tests
cut the power at every step.
"""

import hashlib
import os
import struct

_MAGIC = b"RRPS"
_FORMAT = 1
_HEAD = 7            # magic, format, count
_DIGEST = 32
_TYPE_REAL32 = 9     # MAV_PARAM_TYPE_REAL32, as shared/params.py numbers it
_READ_ONLY = 1       # shared/params.py READ_ONLY flag

#: Where the set comes from after ``load()``.
SOURCE_MAIN = "main"
SOURCE_TMP = "tmp"
SOURCE_BACKUP = "backup"
SOURCE_DEFAULTS = "defaults"


class Files:
    """The board's file system as the store uses it (swap it to test)."""

    def open(self, path, mode):
        return open(path, mode)

    def rename(self, old, new):
        os.rename(old, new)

    def remove(self, path):
        os.remove(path)

    def exists(self, path):
        try:
            os.stat(path)
            return True
        except OSError:
            return False

    # what the flight log's files need besides (firmware/flightlog/files.py)
    def mkdir(self, path):
        os.mkdir(path)

    def listdir(self, path):
        return os.listdir(path)

    def stat(self, path):
        return os.stat(path)

    def statvfs(self, path):
        return os.statvfs(path)


def read_file(fs, path):
    """The bytes of ``path`` on ``fs``, or None when it is missing or will not open."""
    if not fs.exists(path):
        return None
    try:
        f = fs.open(path, "rb")
    except OSError:
        return None
    try:
        return f.read()
    finally:
        f.close()


def load_file(fs, path, decode):
    """``(value, source, problem)`` of the whole file at ``path``: main,
    else a whole ``.tmp`` (a save cut after its check: it finishes that
    save), else ``.bak``; ``source`` is ``SOURCE_MAIN``/``TMP``/``BACKUP``
    or None (nothing whole), ``problem`` why main was not used (or None).
    ``decode(image)`` gives ``(value, None)`` or ``(None, reason)``. A
    leftover ``.tmp`` beside a good main file is an unfinished save's and is
    removed."""
    tmp = path + ".tmp"
    value, why = decode(read_file(fs, path))
    if value is not None:
        if fs.exists(tmp):
            fs.remove(tmp)  # an unfinished save's; the main file won
        return value, SOURCE_MAIN, None
    value, _ = decode(read_file(fs, tmp))
    if value is not None:
        # A save was cut after its check: the new file is whole. Finish it.
        if fs.exists(path):
            fs.remove(path)
        fs.rename(tmp, path)
        return value, SOURCE_TMP, why
    value, _ = decode(read_file(fs, path + ".bak"))
    return value, (SOURCE_BACKUP if value is not None else None), why


def replace_file(fs, path, image, what):
    """Put ``image`` at ``path`` as the table above says: ``.tmp`` written,
    read back and compared, main moved to ``.bak``, ``.tmp`` renamed into
    place. OSError (naming ``what``) when flash fails or reads back wrong."""
    tmp = path + ".tmp"
    bak = path + ".bak"
    f = fs.open(tmp, "wb")
    try:
        f.write(image)
    finally:
        f.close()
    if read_file(fs, tmp) != image:
        fs.remove(tmp)
        raise OSError("%s: %s read back different from what was written" % (what, tmp))
    if fs.exists(bak):
        fs.remove(bak)
    if fs.exists(path):
        fs.rename(path, bak)
    fs.rename(tmp, path)


def encode(table):
    """The file image of ``table``'s current values."""
    has_flags = hasattr(table, "flags")
    body = bytearray(_MAGIC)
    body.append(_FORMAT)
    body.extend(b"\x00\x00")
    count = 0
    for i in range(table.count()):
        if has_flags and table.flags(i) & _READ_ONLY:
            continue
        name = table.name(i).encode()
        if table.type(i) == _TYPE_REAL32:
            kind = b"f"
            value = struct.pack("<f", table.get(i))
        else:
            kind = b"i"
            get_int = getattr(table, "get_int", None)
            v = get_int(i) if get_int else int(table.get(i))
            value = struct.pack("<i", v)
        body.append(len(name))
        body.extend(name)
        body.extend(kind)
        body.extend(value)
        count += 1
    struct.pack_into("<H", body, 5, count)
    body.extend(hashlib.sha256(body).digest())
    return bytes(body)


def decode(data):
    """``(entries, None)`` for a whole file, ``(None, reason)`` otherwise.

    ``entries`` is a list of ``(name, value)``; nothing is trusted before the
    digest matched.
    """
    if data is None:
        return None, "missing"
    n = len(data)
    if n < _HEAD + _DIGEST:
        return None, "truncated (%d bytes)" % n
    if data[:4] != _MAGIC:
        return None, "not a parameter file"
    if data[4] != _FORMAT:
        return None, "format %d, expected %d" % (data[4], _FORMAT)
    end = n - _DIGEST
    if hashlib.sha256(data[:end]).digest() != data[end:]:
        return None, "checksum mismatch"
    count = struct.unpack_from("<H", data, 5)[0]
    entries = []
    at = _HEAD
    for _ in range(count):
        if at >= end:
            return None, "entry table cut short"
        k = data[at]
        if at + 1 + k + 5 > end:
            return None, "entry table cut short"
        name = bytes(data[at + 1:at + 1 + k]).decode()
        kind = data[at + 1 + k]
        if kind == 0x66:    # 'f'
            value = struct.unpack_from("<f", data, at + 2 + k)[0]
        elif kind == 0x69:  # 'i'
            value = struct.unpack_from("<i", data, at + 2 + k)[0]
        else:
            return None, "unknown value kind %d" % kind
        entries.append((name, value))
        at += 6 + k
    if at != end:
        return None, "%d stray bytes after the entries" % (end - at)
    return entries, None


#: What a save stalls the Pico 2 for, at most in practice: writing the
#: new file erases a 4 kB sector (45 ms typical, W25Q32JV datasheet) and
#: programs its pages, the renames commit littlefs metadata (0.4 ms a page),
#: and every sixteenth commit or so compacts a metadata pair (another erase).
SAVE_STALL_MS = 150


class ParamStore:
    """Load and save ``table`` at ``path`` (``path + '.tmp'``, ``'.bak'`` beside it).

    After ``load()``: ``source`` (``main``, ``tmp``, ``backup`` or
    ``defaults``), ``problem`` (why the main file was not used, or None),
    ``loaded``, ``unknown``, ``rejected``. ``save_errors`` and
    ``last_error`` record failed saves of ``service()``.
    """

    def __init__(self, table, path="/params.bin", fs=None):
        self.table = table
        self.path = path
        self.tmp = path + ".tmp"
        self.bak = path + ".bak"
        self.fs = fs if fs is not None else Files()
        self.source = SOURCE_DEFAULTS
        self.problem = None
        self.loaded = 0
        self.unknown = 0
        self.rejected = 0
        self.saves = 0
        self.save_errors = 0
        self.last_error = None
        self._saved_version = getattr(table, "version", 0)
        #: ``expect_delay(ms)``: told before a save stalls the chip (the
        #: scheduler's ``expect_delay_ms``), or None
        self.expect_delay = None
        #: ``may_write()``: False while a save would stall a dive (armed and
        #: moving); None: always. A change then takes effect in RAM at once
        #: and its save waits (``held``), as the flight log's writes do.
        self.may_write = None
        #: ``on_hold(held)``: told when a save starts and stops waiting
        self.on_hold = None
        #: a setting's change waits for its save: a reset now loses it
        #: (``DIVE_STATE`` parameters' changes alone do not count: the
        #: dive's state keeps them)
        self.held = False
        self._saved_settings = getattr(table, "settings_version", 0)

    # ---------------------------------------------------------------- read
    def _apply(self, entries):
        table = self.table
        self.loaded = self.unknown = self.rejected = 0
        for name, value in entries:
            i = table.index(name)
            if i < 0:
                self.unknown += 1
            elif table.set(i, value) != 0:
                self.rejected += 1
            else:
                self.loaded += 1

    def load(self):
        """Fill the table from flash (main, tmp, backup, defaults); the source."""
        entries, source, self.problem = load_file(self.fs, self.path, decode)
        if entries is not None:
            self.source = source
            self._apply(entries)
        else:
            self.source = SOURCE_DEFAULTS
            self.loaded = self.unknown = self.rejected = 0
        self._saved_version = getattr(self.table, "version", 0)
        self._saved_settings = getattr(self.table, "settings_version", 0)
        return self.source

    def describe(self):
        """One line for the start-up log."""
        if self.source == SOURCE_MAIN:
            text = "params: %d loaded from %s" % (self.loaded, self.path)
        elif self.source == SOURCE_DEFAULTS:
            text = "params: defaults (%s: %s, no backup)" % (self.path, self.problem)
        else:
            text = "params: %d loaded from %s (%s: %s)" % (
                self.loaded, self.tmp if self.source == SOURCE_TMP else self.bak, self.path, self.problem)
        if self.unknown or self.rejected:
            text += "; %d unknown, %d rejected" % (self.unknown, self.rejected)
        return text

    # --------------------------------------------------------------- write
    def save(self):
        """Write the table's values; raises OSError when flash fails."""
        replace_file(self.fs, self.path, encode(self.table), "parameter save")
        self.saves += 1
        self._saved_version = getattr(self.table, "version", 0)
        self._saved_settings = getattr(self.table, "settings_version", 0)

    def dirty(self):
        """True when the table changed since the last load or save."""
        return getattr(self.table, "version", 0) != self._saved_version

    def service(self):
        """Scheduler task: save when the table changed; never raises on flash errors.

        A save stalls the chip (``SAVE_STALL_MS``): the loop is told first
        (``expect_delay``, the scheduler's ``expect_delay_ms``), and it
        waits while ``may_write()`` says a dive would pay for it: a ground
        station setting parameters mid-dive would otherwise stall the loop
        for each (200 sets at 20 Hz cost 18 planned stalls, 114 skipped
        slots and the landing 0.012 -> 0.186 m)."""
        if not self.dirty():
            return False
        if self.may_write is not None and not self.may_write():
            if not self.held and getattr(self.table, "settings_version", 1) != self._saved_settings:
                self.held = True
                if self.on_hold is not None:
                    self.on_hold(True)
            return False
        if self.held:
            self.held = False
            if self.on_hold is not None:
                self.on_hold(False)
        if self.expect_delay is not None:
            self.expect_delay(SAVE_STALL_MS)
        try:
            self.save()
            return True
        except OSError as e:
            self.save_errors += 1
            self.last_error = str(e)
            self._saved_version = getattr(self.table, "version", 0)
            self._saved_settings = getattr(self.table, "settings_version", 0)
            return False
