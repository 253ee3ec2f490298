"""ArduPilot's DataFlash log format (``.BIN``), packed into a fixed buffer.

A log is a stream of records, each ``0xA3 0x95 type`` followed by its fields
packed little-endian (ArduPilot, ``libraries/AP_Logger/LogStructure.h``).
Record type 128, FMT, describes every type: its length, a name of up to four
letters, a format (one letter a field) and comma-separated labels. FMTU gives
each field a unit and a multiplier, one letter each, which UNIT and MULT
records define; pymavlink's DFReader (so ``mavlogdump.py`` and MAVExplorer)
and UAV Log Viewer take units from there. DFReader reads UNIT and MULT into
its tables when it meets them and resolves FMTU at once, so a log begins with
FMT, UNIT, MULT and only then FMTU (``header``).

Field letters (LogStructure.h): ``b B h H i I`` integers, ``f`` float32,
``d`` float64, ``n N Z`` strings of 4, 16 and 64 bytes, ``c C`` int16 and
uint16 times 100, ``e E`` int32 and uint32 times 100, ``L`` int32 degrees
times 1e7, ``M`` a flight mode (uint8), ``q Q`` 64-bit integers.

Every record here starts with ``TimeUS`` (``Q``): microseconds since the
board started. A board's small integers have 31 bits, so a 64-bit time
would be a long integer, allocated at each use; ``Clock`` keeps it in two
small integers and a record packs it as ``<HBBI`` (bits 0-15, 16-23, 24-31,
32-63), the same eight bytes.

``Record`` describes one type; ``Writer`` packs records into a bytearray
made once, ``reserve(length)`` giving the offset of the next record or -1
when it would not fit (the caller counts what it drops: a full buffer loses
new records, never old ones). A record's own fields are packed by its
caller with ``struct.pack_into`` and the pack format ``Record.pack``, whose
first arguments are ``Writer.head`` ... the time's four parts; see
``Writer.stamp``.
"""

import struct

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

HEAD1 = const(0xA3)
HEAD2 = const(0x95)
FMT_TYPE = const(128)
FMT_LENGTH = const(89)      # 3 + type, length, name[4], format[16], labels[64]
_FMT_PACK = "<BBBBB4s16s64s"

#: struct code of each field letter (TimeUS's ``Q`` is split: see ``Clock``).
_CODES = {
    "b": "b", "B": "B", "h": "h", "H": "H", "i": "i", "I": "I", "f": "f", "d": "d",
    "n": "4s", "N": "16s", "Z": "64s", "c": "h", "C": "H", "e": "i", "E": "I",
    "L": "i", "M": "B", "q": "q", "Q": "Q",
}
_SIZES = {"b": 1, "B": 1, "h": 2, "H": 2, "i": 4, "I": 4, "f": 4, "d": 8, "n": 4, "N": 16,
          "Z": 64, "c": 2, "C": 2, "e": 4, "E": 4, "L": 4, "M": 1, "q": 8, "Q": 8}

#: Units ArduPilot defines (LogStructure.h ``log_Units``) that our records use.
UNITS = (
    ("-", ""), ("#", "instance"), ("s", "s"), ("m", "m"), ("n", "m/s"), ("o", "m/s/s"),
    ("d", "deg"), ("k", "deg/s"), ("E", "rad/s"), ("G", "Gauss"), ("P", "Pa"), ("O", "degC"),
    ("Y", "us"), ("%", "%"), ("v", "V"), ("A", "A"), ("b", "B"), ("z", "Hz"), ("h", "degheading"),
)
#: Multipliers (LogStructure.h ``log_Multipliers``): ``-`` none, ``0`` 1, ``F`` 1e-6.
MULTS = (("-", 0.0), ("?", 1.0), ("0", 1.0), ("A", 1e-1), ("B", 1e-2), ("C", 1e-3), ("F", 1e-6))

_UNIT_TYPE = const(130)
_MULT_TYPE = const(131)
_FMTU_TYPE = const(129)


class Record:
    """One record type: ``Record(type_id, name, fmt, labels, units, mults)``,
    as in ArduPilot's LogStructure (``fmt``, ``units`` and ``mults`` one
    letter a field, ``labels`` comma-separated). The first field is
    ``TimeUS`` (``Q``, unit ``s``, multiplier ``F``). ``length`` is the
    whole record's bytes, ``pack`` the ``struct`` format that packs it
    with the time in four parts."""

    def __init__(self, type_id, name, fmt, labels, units, mults):
        n = len(fmt)
        if fmt[0] != "Q" or not labels.startswith("TimeUS,") or len(units) != n or len(mults) != n:
            raise ValueError("record %s: TimeUS first, one unit and one multiplier a field" % name)
        if len(labels.split(",")) != n or len(name) > 4 or len(fmt) > 16 or len(labels) > 64:
            raise ValueError("record %s: fields and labels disagree or are too long" % name)
        self.type_id = type_id
        self.name = name
        self.fmt = fmt
        self.labels = labels
        self.units = units
        self.mults = mults
        self.length = 3 + sum(_SIZES[c] for c in fmt)
        self.pack = "<BBBHBBI" + "".join(_CODES[c] for c in fmt[1:])


#: The records that describe the others (types 129-131 follow ArduPilot's
#: LOG_FORMAT_UNITS_MSG, LOG_UNIT_MSG and LOG_MULT_MSG).
FMTU = Record(_FMTU_TYPE, "FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds", "s---", "F---")
UNIT = Record(_UNIT_TYPE, "UNIT", "QbZ", "TimeUS,Id,Label", "s--", "F--")
MULT = Record(_MULT_TYPE, "MULT", "Qbd", "TimeUS,Id,Mult", "s--", "F--")


class Clock:
    """Microseconds since boot, in two small integers: ``lo`` (below 2**24)
    and ``hi`` (units of 2**24 us, ~16.8 s). ``advance(dt_us)`` adds a step
    of at most 2**29 us."""

    def __init__(self):
        self.lo = 0
        self.hi = 0

    def advance(self, dt_us):
        lo = self.lo + dt_us
        while lo >= 0x1000000:
            lo -= 0x1000000
            self.hi += 1
        self.lo = lo

    def set_us(self, t_us):
        """Set from an integer (host side and tests: may be a long integer)."""
        self.hi = t_us >> 24
        self.lo = t_us & 0xFFFFFF

    def us(self):
        """The time as one integer (host side and tests: a long integer on a board)."""
        return (self.hi << 24) + self.lo


class Writer:
    """Records packed into one bytearray of ``size`` bytes, made here once,
    used as a ring that keeps each record whole (a "bip buffer"): a record
    that does not fit before the end starts again at the front, behind the
    oldest bytes not yet taken away.

    ``reserve(n)`` gives the offset of the next ``n``-byte record (and
    counts it as written) or -1 when it does not fit; ``dropped`` counts
    the refusals: a full buffer loses new records, never old ones.
    ``stamp(clock)`` takes the time the next records carry as
    ``t0 .. t3`` (``Record.pack``'s fourth to seventh arguments).
    ``pending()`` is the bytes waiting; ``chunk(most)`` gives ``(offset,
    count)`` of the oldest contiguous run of at most ``most`` of them and
    ``taken(count)`` lets them go once they are safe on flash."""

    def __init__(self, size, buf=None):
        # buf: memory made elsewhere, at least ``size`` bytes (the RAM a
        # watchdog reset keeps, ``logger.FlightLog``); the ring is its first
        # ``size`` bytes
        self.buf = bytearray(size) if buf is None else buf
        self.size = size
        self.head = 0       # where the next record goes
        self.tail = 0       # the oldest byte not yet taken
        self.wrap = -1      # where the data before a wrap ends; -1: no wrap
        self.dropped = 0
        self.t0 = 0
        self.t1 = 0
        self.t2 = 0
        self.t3 = 0

    def stamp(self, clock):
        lo = clock.lo
        hi = clock.hi
        self.t0 = lo & 0xFFFF
        self.t1 = lo >> 16
        self.t2 = hi & 0xFF
        self.t3 = hi >> 8

    def reserve(self, n):
        h = self.head
        if self.wrap < 0:
            if h + n <= self.size:
                self.head = h + n
                return h
            if n < self.tail:      # the front has room: wrap (head never meets tail from behind)
                self.wrap = h
                self.head = n
                return 0
        elif h + n < self.tail:
            self.head = h + n
            return h
        self.dropped += 1
        return -1

    def pending(self):
        if self.wrap < 0:
            return self.head - self.tail
        return self.wrap - self.tail + self.head

    def free(self):
        return self.size - self.pending()

    def chunk(self, most):
        t = self.tail
        end = self.head if self.wrap < 0 else self.wrap
        n = end - t
        return t, (n if n < most else most)

    def taken(self, n):
        t = self.tail + n
        if self.wrap >= 0 and t >= self.wrap:
            t = 0
            self.wrap = -1
        self.tail = t
        if self.wrap < 0 and t == self.head:
            self.tail = 0      # empty: start at the front again
            self.head = 0

    def clear(self):
        """Forget everything waiting (a new log)."""
        self.head = 0
        self.tail = 0
        self.wrap = -1

    # -- the header: once a log, not in flight ---------------------------

    def _fmt(self, r):
        o = self.reserve(FMT_LENGTH)
        if o >= 0:
            struct.pack_into(_FMT_PACK, self.buf, o, HEAD1, HEAD2, FMT_TYPE, r.type_id, r.length,
                             r.name.encode(), r.fmt.encode(), r.labels.encode())
        return o

    def header_items(self, records):
        """How many steps ``header_item`` takes for ``records``."""
        return 4 + len(UNITS) + len(MULTS) + len(records)

    def header_item(self, k, records):
        """Step ``k`` of a log's header: FMT for FMT, UNIT, MULT and FMTU, the
        UNIT and MULT tables, then FMT and FMTU for each of ``records``
        (DFReader resolves a FMTU with the UNIT and MULT it has read).
        False when the buffer has no room. A header in steps lets a log
        start without stalling a slot."""
        buf = self.buf
        if k == 0:
            # FMT describes itself without TimeUS, as ArduPilot's does.
            o = self.reserve(FMT_LENGTH)
            if o < 0:
                return False
            struct.pack_into(_FMT_PACK, buf, o, HEAD1, HEAD2, FMT_TYPE, FMT_TYPE, FMT_LENGTH,
                             b"FMT", b"BBnNZ", b"Type,Length,Name,Format,Columns")
            return True
        k -= 1
        if k < 3:
            return self._fmt((UNIT, MULT, FMTU)[k]) >= 0
        k -= 3
        if k < len(UNITS):
            uid, label = UNITS[k]
            o = self.reserve(UNIT.length)
            if o < 0:
                return False
            struct.pack_into(UNIT.pack, buf, o, HEAD1, HEAD2, UNIT.type_id,
                             self.t0, self.t1, self.t2, self.t3, ord(uid), label.encode())
            return True
        k -= len(UNITS)
        if k < len(MULTS):
            mid, mult = MULTS[k]
            o = self.reserve(MULT.length)
            if o < 0:
                return False
            struct.pack_into(MULT.pack, buf, o, HEAD1, HEAD2, MULT.type_id,
                             self.t0, self.t1, self.t2, self.t3, ord(mid), mult)
            return True
        r = records[k - len(MULTS)]
        if self._fmt(r) < 0:
            return False
        o = self.reserve(FMTU.length)
        if o < 0:
            return False
        struct.pack_into(FMTU.pack, buf, o, HEAD1, HEAD2, FMTU.type_id,
                         self.t0, self.t1, self.t2, self.t3, r.type_id, r.units.encode(), r.mults.encode())
        return True

    def header(self, records):
        """The whole header at once (``header_item`` for every step); False
        when the buffer is too small for it."""
        for k in range(self.header_items(records)):
            if not self.header_item(k, records):
                return False
        return True
