"""The controllers' parameters: the ``CTL_*`` group of ``shared/param_defs.py``
and the fixed wing angles of the modes, read into one ``array('f')``.

``Gains(params)`` takes a ``ParamTable`` (or None: the declared defaults)
and ``refresh()`` re-reads it when its ``version`` has changed (a parameter
set over the link), so a controller step reads a gain as ``k[CTL_...]``:
one array read, no dict, no name look-up. Angles are kept in radians.
"""

from array import array

from roboray.shared import param_defs

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_RAD = 0.017453292519943295

#: Names read, in the order of the index constants below; those ending in
#: _DEG (and _DPS) are converted to radians (per second).
NAMES = ("SERVO_SAFE_DEG", "PASSIVE_WING_DEG", "FS_WING_DEG", "CTL_FOLD_DEG", "CTL_POS_P", "CTL_POS_LEASH",
         "CTL_VEL_P", "CTL_VEL_MAX", "CTL_TGT_K", "CTL_TGT_HMIN", "CTL_DEPTH_M", "CTL_DESC_I",
         "CTL_ATT_P", "CTL_ATT_I", "CTL_SLEW_DPS", "CTL_BS_K", "CTL_BS_KV2")
SAFE = const(0)
PASSIVE = const(1)
FAILSAFE = const(2)
FOLD = const(3)
POS_P = const(4)
POS_LEASH = const(5)
VEL_P = const(6)
VEL_MAX = const(7)
TGT_K = const(8)
TGT_HMIN = const(9)
DEPTH = const(10)
DESC_I = const(11)
ATT_P = const(12)
ATT_I = const(13)
SLEW = const(14)
BS_K = const(15)
BS_KV2 = const(16)
N = const(17)


def _declared():
    """Default of every name in NAMES, from the parameter declarations."""
    found = {}
    for d in param_defs.PARAMS:
        found[d[0]] = d[2]
    out = []
    for name in NAMES:
        if name not in found:
            raise ValueError("parameter %s is not declared in param_defs" % name)
        out.append(float(found[name]))
    return out


class Gains:
    """Gains and fixed wing angles (rad) from a parameter table."""

    def __init__(self, params=None):
        self.params = params
        #: Values in the index order above, radians for angles.
        self.k = array("f", [0.0] * N)
        self._index = [-1] * N
        self._version = -1
        defaults = _declared()
        for i in range(N):
            self.k[i] = self._convert(i, defaults[i])
        if params is not None:
            for i in range(N):
                self._index[i] = params.index(NAMES[i])
        self.refresh()

    @staticmethod
    def _convert(i, value):
        name = NAMES[i]
        if name.endswith("_DEG") or name.endswith("_DPS"):
            return value * _RAD
        return value

    def refresh(self):
        """Re-read the table if it changed; True when it did."""
        p = self.params
        if p is None or p.version == self._version:
            return False
        self._version = p.version
        for i in range(N):
            j = self._index[i]
            if j >= 0:
                self.k[i] = self._convert(i, p.get(j))
        return True
