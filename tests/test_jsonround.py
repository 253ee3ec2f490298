"""JSON figures at their meaningful digits (tools/jsonround.py), through
every --json writer's one path (tools.cli.emit)."""

import argparse
import json
import math
import struct
import subprocess
import sys

import numpy as np
import pytest

from roboray.tools.cli import emit
from roboray.tools.jsonround import FLOOR, rounded


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def test_double_round_off_goes_and_nine_digits_stay():
    assert rounded(10.120000000000001) == 10.12
    assert repr(rounded(0.1 + 0.2)) == "0.3"
    assert rounded(179.32092292073068) == 179.320923
    assert rounded(-0.017743749987799835) == -0.01774375
    assert rounded(9.999999999999995) == 10.0
    # a time stamp since 1970 keeps its microseconds
    assert rounded(1712345678.1234567) == 1712345678.123457


def test_values_below_the_floor_are_zero():
    assert rounded(2.47e-50) == 0.0
    assert rounded(-3.45e-18) == 0.0 and math.copysign(1.0, rounded(-3.45e-18)) == 1.0
    assert rounded(-0.0) == 0.0 and math.copysign(1.0, rounded(-0.0)) == 1.0
    assert rounded(10 * FLOOR) == 10 * FLOOR


def test_a_float32_is_its_shortest_decimal_and_reads_back_to_the_same_bits():
    for text in ("0.1", "-0.0029", "6.6", "101325.01", "3.4e38", "1e-07"):
        x = f32(float(text))
        y = rounded(x)
        assert f32(y) == x, text
        assert y == float(text), (text, y)   # what was typed, not the float32's widened double
    assert rounded(f32(0.1)) == 0.1
    assert rounded(f32(0.123456789)) == 0.12345679


def test_not_finite_is_null_and_the_tree_is_kept():
    out = rounded({"a": [float("nan"), float("inf"), (1.5, np.float32(0.1))], "b": np.array([[1e-20, 2.0]]),
                   "c": np.int64(3), "d": np.bool_(True), "e": "text", "f": None, 7: False})
    assert out == {"a": [None, None, [1.5, 0.1]], "b": [[0.0, 2.0]], "c": 3, "d": True, "e": "text", "f": None,
                   7: False}
    assert type(out["c"]) is int and type(out["d"]) is bool and type(out["b"][0][1]) is float
    json.dumps(out, allow_nan=False)


def test_emit_writes_rounded_strict_json(capsys):
    emit(argparse.Namespace(json=True), {"t": 10.120000000000001, "spin": 2.47e-50, "none": float("nan")})
    text = capsys.readouterr().out
    assert json.loads(text) == {"t": 10.12, "spin": 0.0, "none": None}
    assert "10.120000000000001" not in text and "e-50" not in text and "NaN" not in text


def test_a_command_prints_no_round_off():
    r = subprocess.run([sys.executable, "-m", "roboray.sim.cli", "vehicle", "--json"], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    # the added-mass coupling D: 0.0177 off the diagonal, round-off (3.45e-18) elsewhere
    assert doc["D"][0][1] == -0.01774375 and doc["D"][0][2] == 0.0 and doc["D"][2][0] == 0.0

    def floats(o):
        if isinstance(o, float):
            yield o
        elif isinstance(o, dict):
            for v in o.values():
                yield from floats(v)
        elif isinstance(o, list):
            for v in o:
                yield from floats(v)

    values = list(floats(doc))
    assert len(values) > 20
    for v in values:
        assert v == 0.0 or abs(v) >= FLOOR
        assert v == float("%.9g" % v), v   # nine significant digits at most
