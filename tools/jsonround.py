"""Figures in JSON to their meaningful digits, the one rule of every
``--json`` document of ``roboray-sim`` and ``roboray-ground``.

Doubles carry round-off in their 16th and 17th digits (``10.12`` computed
as ``10.120000000000001``) and quantities that are zero in theory come out
as ``2.47e-50``. A figure is written:

- as ``null`` when it is not finite (strict JSON has no NaN or infinity;
  a NaN here means "none": no equilibrium, not received);
- as ``0`` when its magnitude is below :data:`FLOOR`, 1e-12 in SI units:
  nothing this project measures or models is that small (the inertias are
  1e-3 kg m^2, the Earth's field 5e-5 T), so a value below it is round-off
  of something that is zero (the vehicle's added-mass coupling came out as
  3.45e-18 beside 0.0177);
- as the shortest decimal that is the same float32 when it is exactly a
  float32: it came from the board or over MAVLink (the vehicle's number
  type), where ``0.1`` arrives as ``0.10000000149011612``; the decimal
  reads back to the very same float32 on the vehicle;
- otherwise to :data:`SIGNIFICANT` significant digits (a float32's nine,
  so no figure a double holds is coarser than one the board holds), and
  never to fewer than :data:`DECIMALS` decimals: a time stamp in seconds
  since 1970 keeps its microseconds.

Integers, booleans and strings pass unchanged; numpy scalars and arrays
become their Python values; tuples become lists.
"""

from __future__ import annotations

import math
import struct
from typing import Any

SIGNIFICANT = 9
DECIMALS = 6
FLOOR = 1e-12
_F32_MAX = 3.4028234663852886e38
_F32 = struct.Struct("<f")


def rounded(value: Any) -> Any:
    """``value`` (a JSON-able tree) with every float at its meaningful digits."""
    if isinstance(value, float):   # numpy's float64 too
        return figure(float(value))
    if isinstance(value, (bool, int, str)) or value is None:
        return value
    if isinstance(value, dict):
        return {k: rounded(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [rounded(v) for v in value]
    try:
        import numpy as np
    except ImportError:  # pragma: no cover - numpy is a dependency
        return value
    if isinstance(value, np.ndarray):
        return rounded(value.tolist())
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return figure(float(value))
    return value


def figure(x: float) -> Any:
    """One float by the module's rule (``None`` when not finite)."""
    if not math.isfinite(x):
        return None
    size = abs(x)
    if size < FLOOR:
        return 0.0
    if size <= _F32_MAX and _F32.unpack(_F32.pack(x))[0] == x:
        return _shortest_float32(x)
    digits = max(SIGNIFICANT - 1 - math.floor(math.log10(size)), DECIMALS)
    return round(x, digits) + 0.0


def _shortest_float32(x: float) -> float:
    for precision in range(1, 10):
        text = "%.*g" % (precision, x)
        if _F32.unpack(_F32.pack(float(text)))[0] == x:
            return float(text)
    return x  # not reached: nine digits always name a float32
