"""The vehicle's parameter table: named, typed values with limits.

The firmware declares every parameter once, as a tuple of entries
``(name, type, default, min, max)`` or ``(name, type, default, min, max,
flags)`` (``shared/param_defs.py`` holds the vehicle's); ``ParamTable``
holds their values in buffers made at construction. The MAVLink endpoint
(parameter protocol) and ``firmware/param_store.py`` (flash) use exactly
this API, which is stable:

``count()``
    number of parameters; indices run 0 .. count()-1 in declaration order.
``index(name) -> int``
    index of ``name`` (a str), -1 if unknown; a hash look-up, no allocation.
``find(buf, offset, length) -> int``
    the same for a name held in bytes (a MAVLink ``param_id``: up to 16
    bytes, NUL-padded when shorter), without building a str.
``name(i)``, ``type(i)``, ``minimum(i)``, ``maximum(i)``, ``default(i)``, ``flags(i)``
    the declaration of parameter ``i``; ``type`` is a ``MAV_PARAM_TYPE``;
    ``name`` (str) and ``name_bytes`` (bytes) make a new object each call.
``get(i) -> float``
    current value (integers are exact as floats up to 2**24).
``set(i, value) -> int``
    ``OK`` (0) or an error: ``ERR_RANGE`` (outside min..max), ``ERR_TYPE``
    (not a finite number, or not a whole number for an integer type),
    ``ERR_READ_ONLY``, ``ERR_INDEX``. A rejected value changes nothing.
``set_by_name(name, value) -> int``
    ``set`` by name; ``ERR_UNKNOWN`` for an unknown name.
``defaults()``
    every parameter back to its default.
``version``
    counts successful changes, so a store can tell when to save.

Types: ``TYPE_UINT8``, ``TYPE_INT8``, ``TYPE_UINT16``, ``TYPE_INT16``,
``TYPE_INT32`` and ``TYPE_REAL32``, numbered as MAVLink's ``MAV_PARAM_TYPE``;
their values cross the link as floats (MAVLink's "C cast" encoding).
"""

from array import array

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

TYPE_UINT8 = const(1)
TYPE_INT8 = const(2)
TYPE_UINT16 = const(3)
TYPE_INT16 = const(4)
TYPE_INT32 = const(6)
TYPE_REAL32 = const(9)

#: Natural limits of each integer type: (min, max).
_LIMITS = {
    TYPE_UINT8: (0, 255), TYPE_INT8: (-128, 127), TYPE_UINT16: (0, 65535),
    TYPE_INT16: (-32768, 32767), TYPE_INT32: (-2147483648, 2147483647),
}

OK = const(0)
ERR_RANGE = const(1)
ERR_TYPE = const(2)
ERR_READ_ONLY = const(3)
ERR_UNKNOWN = const(4)
ERR_INDEX = const(5)

#: Text for each error code, for logs and the ground station.
ERRORS = ("ok", "out of range", "wrong type", "read only", "unknown parameter", "no such index")

#: Declaration flag: the value cannot be set over the link.
READ_ONLY = const(1)
#: Declaration flag: the firmware sets it itself in a dive and the dive's
#: state keeps it through a reset (``firmware/dive_state.py``: the surface
#: pressure set at arming), so its change alone leaves nothing a reset
#: would lose while the save waits (``settings_version`` does not count it).
DIVE_STATE = const(2)

NAME_LEN = const(16)


def _hash(buf, offset, length):
    # Small-integer hash of a NUL-terminated name: stays below 2**24.
    h = 0
    for i in range(offset, offset + length):
        c = buf[i]
        if c == 0:
            break
        h = (h * 31 + c) & 0xFFFFFF
    return h


class ParamTable:
    """Values for a declaration tuple; see the module docstring for the API."""

    def __init__(self, decls):
        n = len(decls)
        # The names in one bytes object (``_at[i]`` to ``_at[i + 1]``), not
        # a list of str and bytes: 79 small objects a collection would
        # scan, and a list pushing them all onto its mark stack at once
        # (``firmware/collector.py``).
        self._at = array("H", [0] * (n + 1))
        self._types = bytearray(n)
        self._flags = bytearray(n)
        self._default = array("f", [0.0] * n)
        self._min = array("f", [0.0] * n)
        self._max = array("f", [0.0] * n)
        self._imin = array("l", [0] * n)  # integer limits: compared without boxing a float
        self._imax = array("l", [0] * n)
        self._idefault = array("l", [0] * n)
        self._ival = array("l", [0] * n)   # integer types: exact
        self._fval = array("f", [0.0] * n)  # REAL32
        self._hashed = {}
        #: counts every change; ``settings_version`` those to parameters
        #: only flash keeps (not ``DIVE_STATE`` ones)
        self.version = 0
        self.settings_version = 0
        names = []
        seen = {}
        for i in range(n):
            d = decls[i]
            if len(d) not in (5, 6):
                raise ValueError("parameter %r: expected (name, type, default, min, max[, flags])" % (d,))
            name, ptype, default, lo, hi = d[0], d[1], d[2], d[3], d[4]
            if not isinstance(name, str) or not 0 < len(name) <= NAME_LEN:
                raise ValueError("parameter name %r must be 1..16 characters" % (name,))
            if name in seen:
                raise ValueError("parameter %s declared twice" % name)
            if ptype != TYPE_REAL32 and ptype not in _LIMITS:
                raise ValueError("parameter %s: unsupported type %r" % (name, ptype))
            if ptype in _LIMITS:
                tlo, thi = _LIMITS[ptype]
                if lo < tlo or hi > thi or lo != int(lo) or hi != int(hi):
                    raise ValueError("parameter %s: limits %r..%r do not fit its type" % (name, lo, hi))
            if not lo <= default <= hi:
                raise ValueError("parameter %s: default %r outside %r..%r" % (name, default, lo, hi))
            seen[name] = i
            b = name.encode()
            names.append(b)
            self._at[i + 1] = self._at[i] + len(b)
            self._types[i] = ptype
            self._flags[i] = d[5] if len(d) == 6 else 0
            self._default[i] = default
            self._min[i] = lo
            self._max[i] = hi
            if ptype != TYPE_REAL32:
                self._imin[i] = int(lo)
                self._imax[i] = int(hi)
                self._idefault[i] = int(default)
            h = _hash(b, 0, len(b))
            self._hashed[h] = -2 if h in self._hashed else i  # -2: collision, scan
        self._names = b"".join(names)
        self.defaults()
        self.version = 0
        self.settings_version = 0

    # ------------------------------------------------------------ look-up
    def count(self):
        return len(self._types)

    def index(self, name):
        n = len(name)
        if not 0 < n <= NAME_LEN:
            return -1
        h = 0
        for k in range(n):
            # a one-character str is an interned qstr on MicroPython: no allocation
            h = (h * 31 + ord(name[k])) & 0xFFFFFF
        i = self._hashed.get(h, -1)
        if i >= 0:
            return i if self._same_str(i, name) else -1
        if i == -2:
            for j in range(len(self._types)):
                if self._same_str(j, name):
                    return j
        return -1

    def _same_str(self, i, name):
        names = self._names
        a = self._at[i]
        n = self._at[i + 1] - a
        if n != len(name):
            return False
        for k in range(n):
            if ord(name[k]) != names[a + k]:
                return False
        return True

    def find(self, buf, offset, length=NAME_LEN):
        """Index of the NUL-padded name in ``buf[offset:offset+length]``, or -1."""
        i = self._hashed.get(_hash(buf, offset, length), -1)
        if i >= 0:
            return i if self._same(i, buf, offset, length) else -1
        if i == -2:
            for j in range(len(self._types)):
                if self._same(j, buf, offset, length):
                    return j
        return -1

    def _same(self, i, buf, offset, length):
        names = self._names
        a = self._at[i]
        n = self._at[i + 1] - a
        if n > length:
            return False
        for k in range(n):
            if buf[offset + k] != names[a + k]:
                return False
        return n == length or buf[offset + n] == 0

    def name(self, i):
        return self.name_bytes(i).decode()

    def name_bytes(self, i):
        """The name as bytes (what goes into a MAVLink ``param_id``; a new
        object: the names share one)."""
        return self._names[self._at[i]:self._at[i + 1]]

    def type(self, i):
        return self._types[i]

    def flags(self, i):
        return self._flags[i]

    def minimum(self, i):
        return self._min[i]

    def maximum(self, i):
        return self._max[i]

    def default(self, i):
        return self._default[i]

    # ------------------------------------------------------------- values
    def get(self, i):
        if self._types[i] == TYPE_REAL32:
            return self._fval[i]
        return float(self._ival[i])

    def get_int(self, i):
        """Value of an integer parameter without boxing a float."""
        if self._types[i] == TYPE_REAL32:
            return int(self._fval[i])
        return self._ival[i]

    def set(self, i, value):
        if not 0 <= i < len(self._types):
            return ERR_INDEX
        if self._flags[i] & READ_ONLY:
            return ERR_READ_ONLY
        return self._store(i, value)

    def set_by_name(self, name, value):
        i = self.index(name)
        if i < 0:
            return ERR_UNKNOWN
        return self.set(i, value)

    def _store(self, i, value):
        t = type(value)
        if t is not int and t is not float:
            return ERR_TYPE
        if t is float and value - value != 0:  # NaN or infinite
            return ERR_TYPE
        if self._types[i] == TYPE_REAL32:
            if value < self._min[i] or value > self._max[i]:
                return ERR_RANGE
            self._fval[i] = value
        else:
            iv = int(value)
            if iv != value:
                return ERR_TYPE
            if iv < self._imin[i] or iv > self._imax[i]:
                return ERR_RANGE
            self._ival[i] = iv
        self.version += 1
        if not self._flags[i] & DIVE_STATE:
            self.settings_version += 1
        return OK

    def defaults(self):
        """Every parameter to its declared default (read-only ones included)."""
        for i in range(len(self._types)):
            if self._types[i] == TYPE_REAL32:
                self._fval[i] = self._default[i]
            else:
                self._ival[i] = self._idefault[i]
        self.version += 1
        self.settings_version += 1
