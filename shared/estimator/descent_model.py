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

The parameters are this table, and only this table, fitted by least
squares to the standard scenario's truth from the dynamics model
(``roboray.sim.estimation.calibrate_descent_model``, seeds 0-9 of the
``dynamics`` source): residual 2.7 mm/s, against 13.7 mm/s for the tilt
term alone with wings stepped at once. The fitted D = 0.422 is close to
the trims' 0.345 (the fit also sees the glide of moving and tilted wings);
no lag fits best: the added mass turns the velocity within the 10 ms step. K comes out
negative with flat wings: during feathering the vehicle swings towards its
upper edge, the tilt following the velocity rather than causing it.
"""

#: Mean wing fold at each row, degrees (increasing).
FOLD_DEG = (0.0, 45.0, 90.0)
#: Glide gain K at each row: horizontal speed per (descent speed x tan tilt).
GLIDE_GAIN = (-2.462, -1.069, 0.323)
#: Body-frame glide per unit descent speed per 90 deg of differential fold.
DIFF_GAIN = 0.422
#: Lag of the horizontal velocity behind v_ss, s (0: no lag).
TAU_S = 0.0


def glide_gain(fold_deg):
    """K at a mean fold (deg), linear between the rows, held beyond them."""
    if fold_deg <= FOLD_DEG[0]:
        return GLIDE_GAIN[0]
    n = len(FOLD_DEG)
    for i in range(1, n):
        f1 = FOLD_DEG[i]
        if fold_deg <= f1:
            f0 = FOLD_DEG[i - 1]
            g0 = GLIDE_GAIN[i - 1]
            return g0 + (GLIDE_GAIN[i] - g0) * (fold_deg - f0) / (f1 - f0)
    return GLIDE_GAIN[n - 1]


def glide_vector(s1, s2, s3, s4):
    """Body-frame (x, y) glide per unit descent speed from differential
    folding, wing angles in rad: DIFF_GAIN * (s1 - s3, s2 - s4) / (pi / 2)."""
    k = DIFF_GAIN * 0.6366197723675814  # 1 / (pi / 2)
    return k * (s1 - s3), k * (s2 - s4)
