"""The parameter table: types, limits, look-ups without allocation."""

from __future__ import annotations

import math

import pytest

from roboray.shared import param_defs
from roboray.shared import params as P

DECLS = (
    ("ALPHA", P.TYPE_REAL32, 1.5, -2.0, 2.0),
    ("COUNT", P.TYPE_INT32, 10, 0, 100000),
    ("FLAG", P.TYPE_UINT8, 1, 0, 1),
    ("FIXED", P.TYPE_INT16, 7, 0, 10, P.READ_ONLY),
    ("EXACTLY_SIXTEEN_", P.TYPE_INT8, -3, -5, 5),
)


def test_api_reads_the_declaration():
    t = P.ParamTable(DECLS)
    assert t.count() == 5
    assert [t.name(i) for i in range(5)] == [d[0] for d in DECLS]
    assert t.index("COUNT") == 1 and t.index("NOPE") == -1
    assert t.type(0) == P.TYPE_REAL32 and t.type(2) == P.TYPE_UINT8
    assert t.get(0) == 1.5 and t.get(1) == 10.0 and isinstance(t.get(1), float)
    assert t.minimum(1) == 0 and t.maximum(1) == 100000 and t.default(4) == -3
    assert t.flags(3) == P.READ_ONLY


def test_set_enforces_range_type_and_read_only_and_changes_nothing_on_error():
    t = P.ParamTable(DECLS)
    v0 = t.version
    assert t.set(0, 2.5) == P.ERR_RANGE and t.get(0) == 1.5
    assert t.set(0, math.nan) == P.ERR_TYPE and t.set(0, math.inf) == P.ERR_TYPE
    assert t.set(1, 3.5) == P.ERR_TYPE and t.get(1) == 10.0
    assert t.set(2, 2) == P.ERR_RANGE
    assert t.set(3, 5) == P.ERR_READ_ONLY and t.get(3) == 7.0
    assert t.set(9, 1) == P.ERR_INDEX and t.set(-1, 1) == P.ERR_INDEX
    assert t.set(1, "12") == P.ERR_TYPE
    assert t.version == v0
    assert t.set(1, 12.0) == P.OK and t.get(1) == 12.0 and t.get_int(1) == 12
    assert t.set_by_name("ALPHA", -2.0) == P.OK and t.get(0) == -2.0
    assert t.set_by_name("GAMMA", 1) == P.ERR_UNKNOWN
    assert t.version == v0 + 2
    t.defaults()
    assert t.get(0) == 1.5 and t.get(1) == 10.0


def test_int32_keeps_every_integer():
    t = P.ParamTable((("BIG", P.TYPE_INT32, 0, -2147483648, 2147483647),))
    assert t.set(0, 16777217) == P.OK and t.get_int(0) == 16777217  # 2**24 + 1: not a float32


def test_find_by_nul_padded_bytes():
    t = P.ParamTable(DECLS)
    buf = bytearray(40)
    buf[4:9] = b"COUNT"
    assert t.find(buf, 4, 16) == 1
    buf[4:20] = b"EXACTLY_SIXTEEN_"  # no NUL at all: the full 16 bytes
    assert t.find(buf, 4, 16) == 4
    buf[4:20] = b"COUNTX" + bytes(10)
    assert t.find(buf, 4, 16) == -1
    buf[4:20] = b"COUN" + bytes(12)
    assert t.find(buf, 4, 16) == -1


@pytest.mark.parametrize("bad", [
    (("X", P.TYPE_REAL32, 5.0, 0.0, 1.0),),                  # default outside limits
    (("X", 99, 0, 0, 1),),                                   # unknown type
    (("X", P.TYPE_UINT8, 0, 0, 300),),                       # limits beyond the type
    (("SEVENTEEN_CHARS__", P.TYPE_UINT8, 0, 0, 1),),         # name too long
    (("X", P.TYPE_UINT8, 0, 0, 1), ("X", P.TYPE_UINT8, 0, 0, 1)),  # twice
    (("X", P.TYPE_UINT8, 0, 0),),                            # short entry
])
def test_bad_declarations_are_refused(bad):
    with pytest.raises(ValueError):
        P.ParamTable(bad)


def test_vehicle_declares_the_parameters_the_issues_name():
    t = P.ParamTable(param_defs.PARAMS)
    for name in ("FS_GCS_ENABLE", "FS_GCS_TIMEOUT", "FS_LEAK_ENABLE", "FS_EKF_ACTION", "FS_EKF_THRESH",
                 "BATT_FS_LOW_ACT", "SYSID_THISMAV", "SYSID_MYGCS", "SR_ATTITUDE", "SR_POSITION"):
        assert t.index(name) >= 0, name


def test_on_micropython_lookups_and_sets_allocate_nothing(micropython):
    setup = (
        "from roboray.shared import param_defs\nfrom roboray.shared.params import ParamTable\n"
        "__t = ParamTable(param_defs.PARAMS)\n__b = bytearray(16)\n__b[0:14] = b'FS_GCS_TIMEOUT'\n"
        "def __look():\n    return __t.index('FS_EKF_THRESH') + __t.find(__b, 0, 16)\n"
        "def __seti():\n    return __t.set(__t.index('FS_GCS_ENABLE'), 0)\n"
    )
    assert micropython.alloc_bytes("__look()", setup) == 0
    assert micropython.alloc_bytes("__seti()") == 0
    # a REAL32 set compares against its float limits: a few boxed floats at most
    assert micropython.alloc_bytes("__t.set(3, 2.5)") <= 64
    assert micropython.eval("__t.find(__b, 0, 16)") == micropython.eval("__t.index('FS_GCS_TIMEOUT')")
    assert micropython.eval("__t.set_by_name('FS_GCS_TIMEOUT', 500.0)") == P.ERR_RANGE
