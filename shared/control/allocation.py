"""Wing allocation: a requested glide and mean fold to four wing angles.

The glide a wing configuration gives is a property of the vehicle, found
offline from the model's steady descents (``tools/gen_allocation.py``) and
compiled into ``allocation_table``. The family is the harmonic fold

    s_i = clip(c + A cos(psi - (i - 1) pi/2), 0, pi/2)

(``c`` mean fold: descent speed; ``A`` asymmetry: glide ratio; ``psi`` the
side folded most: the vehicle glides towards its folded side). The table
gives (psi, A) for a glide direction in the octant [0, pi/4] and a glide
ratio, per fold row; the vehicle's symmetry (quarter turns, mirror about
the diagonal) maps any direction into that octant and the harmonic family
maps back by turning psi alike, so no wing relabelling is needed.

Lookup in fixed arrays: A trilinear in (fold, direction, ratio), psi
bilinear from the nearer fold row; a call boxes 56 floats on a fold row
(the default) and 85 between two on a board, and allocates nothing else.
"""

import math
from array import array

from roboray.shared.control import allocation_table as T

_HALF_PI = 1.5707963267948966
_QUARTER_PI = 0.7853981633974483
_TWO_PI = 6.283185307179586
_INV_HALF_PI = 0.6366197723675814


class Allocation:
    """Wing angles for a glide (board code).

    ``wings(fold, gx, gy)`` writes ``s`` (4 angles, rad) for a glide vector
    ``(gx, gy)`` in the body frame (horizontal velocity over descent speed;
    x towards wing 1, y towards wing 2) at mean fold ``fold`` (rad, clamped
    to the table's rows). Returns the reach in that direction (the largest
    glide ratio the table has there); a longer request is shortened to it
    keeping its direction, and ``saturated`` is set.
    """

    def __init__(self):
        #: Wing angles, rad.
        self.s = array("f", [0.0, 0.0, 0.0, 0.0])
        #: The last request was beyond the reach.
        self.saturated = False
        #: Harmonic fold of the last call: side psi (rad), asymmetry A (rad).
        self.psi = 0.0
        self.amp = 0.0
        #: Range of mean folds the table covers, rad.
        self.fold_min = T.FOLD[0]
        self.fold_max = T.FOLD[T.N_FOLD - 1]
        self._fi = 0
        self._fu = 0.0
        self._inv_fold = 1.0 / T.FOLD_STEP
        self._inv_dir = 1.0 / T.DIR_STEP
        self._inv_ratio = 1.0 / T.RATIO_STEP

    def descent(self, fold):
        """Descent speed (m/s) of the symmetric fall at ``fold`` (rad)."""
        self._fold_index(fold)
        i = self._fi
        d = T.DESCENT
        a = d[i]
        return a + (d[i + 1] - a) * self._fu

    def fold_for(self, speed):
        """The mean fold (rad) whose symmetric fall descends at ``speed``
        (m/s), clamped to the table's rows."""
        d = T.DESCENT
        n = T.N_FOLD
        if speed <= d[0]:
            return self.fold_min
        for i in range(1, n):
            if speed <= d[i]:
                return T.FOLD[i - 1] + T.FOLD_STEP * (speed - d[i - 1]) / (d[i] - d[i - 1])
        return self.fold_max

    def _fold_index(self, fold):
        """Row ``_fi`` and weight ``_fu`` of ``fold`` (attributes: a
        returned tuple would be allocated). A fold within 1e-4 of a row is
        on it (weight exactly 0, or 1 on the last row), so the lookups read
        one row only."""
        x = (fold - self.fold_min) * self._inv_fold
        last = T.N_FOLD - 1
        if x >= last - 1e-4:
            self._fi = last - 1
            self._fu = 1.0
            return
        if x <= 1e-4:
            self._fi = 0
            self._fu = 0.0
            return
        i = int(x + 1e-4)
        u = x - i
        if u < 1e-4:
            u = 0.0
        self._fi = i
        self._fu = u

    def wings(self, fold, gx, gy):
        if fold < self.fold_min:
            fold = self.fold_min
        elif fold > self.fold_max:
            fold = self.fold_max
        ratio = math.sqrt(gx * gx + gy * gy)
        # Direction folded into the octant: q quarter turns, then a mirror.
        d = math.atan2(gy, gx)
        if d < 0.0:
            d += _TWO_PI
        q = int(d * _INV_HALF_PI)
        if q > 3:
            q = 3
        d -= q * _HALF_PI
        mirror = d > _QUARTER_PI
        if mirror:
            d = _HALF_PI - d
        self._fold_index(fold)
        fi = self._fi
        fu = self._fu
        x = d * self._inv_dir
        dj = int(x)
        if dj >= T.N_DIR - 1:
            dj = T.N_DIR - 2
        dv = x - dj
        # reach at this fold and direction, bilinear
        rm = T.RATIO_MAX
        k = fi * T.N_DIR + dj
        if fu == 1.0:
            # on the upper row (the default fold): one row, not two
            k += T.N_DIR
        reach = rm[k]
        reach = reach + (rm[k + 1] - reach) * dv
        if 0.0 < fu < 1.0:
            k += T.N_DIR
            r1 = rm[k]
            r1 = r1 + (rm[k + 1] - r1) * dv
            reach = reach + (r1 - reach) * fu
        self.saturated = ratio > reach
        if self.saturated:
            ratio = reach
        x = ratio * self._inv_ratio
        rk = int(x)
        if rk >= T.N_RATIO - 1:
            rk = T.N_RATIO - 2
        rw = x - rk
        base = (fi * T.N_DIR + dj) * T.N_RATIO + rk
        # psi differs by under 2.5 deg between fold rows wherever both reach
        # (the loop takes up the rest): from the nearer row, a boxed float
        # budget saved; A from both
        psi = self._trilinear(T.PSI, base, 0.0 if fu < 0.5 else 1.0, dv, rw)
        amp = self._trilinear(T.AMP, base, fu, dv, rw)
        if mirror:
            psi = _HALF_PI - psi
        psi += q * _HALF_PI
        self.psi = psi
        self.amp = amp
        c = amp * math.cos(psi)
        s = amp * math.sin(psi)
        out = self.s
        out[0] = _clip(fold + c)
        out[1] = _clip(fold + s)
        out[2] = _clip(fold - c)
        out[3] = _clip(fold - s)
        return reach

    def _trilinear(self, t, k, fu, dv, rw):
        """Value of table ``t`` at weights (fold fu, direction dv, ratio rw)
        from the cell whose first corner is index ``k``. Each corner is read
        once (a read boxes a float on a board), and a fold on a row (fu 0
        or 1) reads that row only."""
        nr = T.N_RATIO
        if fu == 1.0:
            k += T.N_DIR * nr
        a = t[k]
        a = a + (t[k + 1] - a) * rw
        b = t[k + nr]
        b = b + (t[k + nr + 1] - b) * rw
        lo = a + (b - a) * dv
        if fu == 0.0 or fu == 1.0:
            return lo
        k += T.N_DIR * nr
        a = t[k]
        a = a + (t[k + 1] - a) * rw
        b = t[k + nr]
        b = b + (t[k + nr + 1] - b) * rw
        hi = a + (b - a) * dv
        return lo + (hi - lo) * fu


def _clip(s):
    if s < 0.0:
        return 0.0
    if s > _HALF_PI:
        return _HALF_PI
    return s
