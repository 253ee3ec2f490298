"""Dead-reckoning descent model: how fast the vehicle glides sideways.

Two causes, from the dynamics model (``roboray.sim.analysis.trim``):

- **Differential folding.** Folding one side more than the other makes the
  vehicle glide towards the folded side: in body axes the steady horizontal
  velocity is ``w * DIFF_GAIN * ((s1 - s3), (s2 - s4)) / 90 deg`` (wing 1
  on +x_c, wing 2 on +y_c). From the trims: (0, 45, 90, 45) glides at 0.345
  of its descent speed towards wing 3, (0, 0, 90, 90) at 0.488 towards the
  folded pair (0.345 along each axis), (0, 0, 90, 0) at 0.293.
- **Tilt** (the thesis's feathering, sec. 5.1): a tilted plate glides
  towards an edge, ``-K(fold) * w * (r02, r12) / r22`` in NED, with
  ``(r02, r12, r22)`` the body z axis in NED.

``w``: descent speed (m/s, from the depth filter); ``fold``: mean of the
four wing angles, degrees. The horizontal velocity follows the sum through a
first-order lag of ``TAU_S``. What the model misses (water current, gain
error) the horizontal filter estimates as a slowly varying velocity bias.

The defaults are this table, and only this table, fitted by least
squares to the standard scenario's truth from the dynamics model
(``roboray.sim.estimation.calibrate_descent_model``, seeds 0-9 of the
``dynamics`` source): residual 2.7 mm/s, against 13.7 mm/s for the tilt
term alone with wings stepped at once. The fitted D = 0.422 is close to
the trims' 0.345 (the fit also sees the glide of moving and tilted wings);
no lag fits best: the added mass turns the velocity within the 10 ms step. K comes out
negative with flat wings: during feathering the vehicle swings towards its
upper edge, the tilt following the velocity rather than causing it.

That calibration is the reference vehicle's in the simulator. A built
vehicle glides as its own drag, added mass and ballast make it, so the
table is the ``DR_*`` parameters (``PARAM_NAMES``), which the firmware
reads at start (``from_params``) and ``roboray-sim identify --params-out``
fits to the vehicle identified from its own dive's log.
"""

#: Mean wing fold at each row, degrees (increasing).
FOLD_DEG = (0.0, 45.0, 90.0)
#: Glide gain K at each row: horizontal speed per (descent speed x tan tilt).
GLIDE_GAIN = (-2.462, -1.069, 0.323)
#: Body-frame glide per unit descent speed per 90 deg of differential fold.
DIFF_GAIN = 0.422
#: Lag of the horizontal velocity behind v_ss, s (0: no lag).
TAU_S = 0.0
#: The parameters the vehicle reads the table from at start
#: (``shared/param_defs.py`` DESCENT, today's values the defaults):
#: K at each fold row, D, the lag. ``roboray-sim identify --params-out``
#: writes them fitted to a vehicle's own dive.
PARAM_NAMES = ("DR_GLIDE_K0", "DR_GLIDE_K45", "DR_GLIDE_K90", "DR_DIFF_K", "DR_TAU")

_INV_QUARTER_TURN = 0.6366197723675814  # 1 / (pi / 2)


class DescentModel:
    """The table of one vehicle: K at ``FOLD_DEG``'s rows, D and the lag."""

    def __init__(self, glide_gain=GLIDE_GAIN, diff_gain=DIFF_GAIN, tau_s=TAU_S):
        if len(glide_gain) != len(FOLD_DEG):
            raise ValueError("glide_gain needs %d values (one a fold row), got %d"
                             % (len(FOLD_DEG), len(glide_gain)))
        if tau_s < 0.0:
            raise ValueError("tau_s %r must be >= 0 s" % tau_s)
        # a tuple of the floats as given: CPython keeps them exact, where an
        # array('f') would round them to single precision
        self.gain = tuple(float(g) for g in glide_gain)
        self.diff_gain = float(diff_gain)
        self.tau_s = float(tau_s)
        # D / (pi / 2), once: the glide vector's one factor
        self._k = self.diff_gain * _INV_QUARTER_TURN

    def glide_gain(self, fold_deg):
        """K at a mean fold (deg), linear between the rows, held beyond them."""
        g = self.gain
        if fold_deg <= FOLD_DEG[0]:
            return g[0]
        n = len(FOLD_DEG)
        for i in range(1, n):
            f1 = FOLD_DEG[i]
            if fold_deg <= f1:
                f0 = FOLD_DEG[i - 1]
                g0 = g[i - 1]
                return g0 + (g[i] - g0) * (fold_deg - f0) / (f1 - f0)
        return g[n - 1]

    def glide_vector(self, s1, s2, s3, s4, out):
        """Body-frame (x, y) glide per unit descent speed from differential
        folding into ``out[0]``, ``out[1]``, wing angles in rad:
        D (s1 - s3, s2 - s4) / (pi / 2)."""
        k = self._k
        out[0] = k * (s1 - s3)
        out[1] = k * (s2 - s4)


def from_params(params):
    """The table in a ``ParamTable``'s ``DR_*`` parameters (read at start)."""
    v = [params.get(params.index(n)) for n in PARAM_NAMES]
    return DescentModel((v[0], v[1], v[2]), v[3], v[4])


#: Today's table, for code that has no parameters (tests, analyses).
DEFAULT = DescentModel()


def glide_gain(fold_deg):
    """K at a mean fold (deg) of today's table (``DEFAULT.glide_gain``)."""
    return DEFAULT.glide_gain(fold_deg)


def glide_vector(s1, s2, s3, s4, out):
    """Today's table's differential glide into ``out`` (``DEFAULT.glide_vector``)."""
    DEFAULT.glide_vector(s1, s2, s3, s4, out)
