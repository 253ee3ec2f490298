"""Dead-reckoning descent model: how fast the vehicle glides sideways.

A tilted plate falling through water glides towards its lower edge (the
thesis's feathering, sec. 5.1): the water's normal force on the plate leans
with it. The model keeps only that::

    v_ss = K(fold) * w * tan(tilt) * (unit vector towards the lower edge)
         = -K(fold) * w * (r02, r12) / r22                 (north, east)

``w``: descent speed (m/s, from the depth filter); ``(r02, r12, r22)``: the
body z axis in NED (third column of the body -> NED rotation), whose
horizontal part leans away from the lower edge; ``fold``: mean of the four
wing angles, 0 (flat) to 90 deg. The horizontal velocity follows ``v_ss``
through a first-order lag of ``TAU_S`` (added mass keeps the vehicle from
turning its velocity at once). What the model misses (water current, gain
error) the horizontal filter estimates as a slowly varying velocity bias.

The parameters are this table, and only this table. Calibrated by a least
squares fit of the standard scenario's truth (``roboray.sim.estimation.
calibrate_descent_model``, seeds 0-9 of the kinematic source, K linear in
the fold: residual 2.2 mm/s; without the lag the best fit leaves 17 mm/s;
the scenario's wings reach 60 deg, so the 90 deg row is extrapolated); to
recalibrate from the dynamics
model's trims, fit ``K`` at each fold from steady glides (``K = v_h r22 /
(w |(r02, r12)|)``) and ``TAU_S`` from the velocity's response to a tilt
step, and write them here. ``K`` may come out negative if the vehicle glides
towards its upper edge.
"""

#: Mean wing fold at each row, degrees (increasing).
FOLD_DEG = (0.0, 45.0, 90.0)
#: Glide gain K at each row: horizontal speed per (descent speed x tan tilt).
GLIDE_GAIN = (0.947, 0.796, 0.646)
#: Lag of the horizontal velocity behind v_ss, s (0: no lag).
TAU_S = 0.5


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
