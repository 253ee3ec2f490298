"""Why the thesis's control law cannot steer: the authority of a
differential wing deflection through the steady path (drag and CG shift)
against the thesis's only path, the added-mass reaction."""

from __future__ import annotations

import math

import numpy as np

from roboray.sim.dynamics import Model
from roboray.sim.flight import FlightSpec, vehicle_params


def authority(fold_deg: float = 45.0) -> dict:
    """Why the thesis's law cannot steer, at the straight fall of the
    symmetric ``fold_deg`` configuration, for a differential deflection
    delta of wings 1 and 3 (s1 = c + delta, s3 = c - delta):

    - the steady path (what the cascade uses): the horizontal force of the
      deflected plates through drag and the CG shift at the fall's velocity
      (dF_x/d delta, N/rad; a column of the linearisation's input matrix
      with the wings held), and the glide it settles into (m/s per rad);
    - the thesis's path, its inputs' only one: the added-mass reaction, the
      velocity rows of G_b = -M_vv^-1 M_vs (body acceleration per wing
      acceleration, m/s^2 per rad/s^2), its peak at the servos' largest
      acceleration (rate limit over lag), and what it leaves: momentum is
      conserved while a wing moves, so a stroke displaces the body by the
      same matrix times the stroke (m per rad) and nothing more; the wing's
      travel bounds it for good.
    """
    from roboray.sim.analysis.trim import attitude_from_gamma, solve_trim

    params = vehicle_params(FlightSpec())
    model = Model(params)
    s0 = np.full(4, math.radians(fold_deg))
    trim = solve_trim(model, s0)
    if trim is None:
        raise RuntimeError("no straight fall at %g deg" % fold_deg)
    q = attitude_from_gamma(trim.gamma)
    e = np.array([1.0, 0.0, -1.0, 0.0])

    def force(s):
        x = model.state(attitude=q, velocity=trim.V, wings=s)
        return model.body_rhs(x, np.zeros((1, 4)))[0, 7:13]

    h = 1e-5
    d_force = (force(s0 + h * e) - force(s0 - h * e)) / (2 * h)
    mvv, mvs = model.inertia(s0[None])
    reaction = -np.linalg.solve(mvv[0], mvs[0] @ e)   # G_b velocity rows times e
    accel_max = params.servo_rate / params.servo_tau  # rad/s^2 at the start of a large step
    stroke = math.radians(min(fold_deg, 90.0 - fold_deg))
    delta = math.radians(8.0)
    glide = solve_trim(model, s0 + delta * e, spiral=False)
    v_per_rad = glide.horizontal_speed / delta if glide is not None else float("nan")
    toward = glide is not None and abs(glide.glide_direction_deg) < 90.0
    return {
        "fold_deg": fold_deg,
        "descent_speed_mps": trim.descent_speed,
        "steady_force_n_per_rad": float(d_force[0]),
        "steady_glide_mps_per_rad": v_per_rad,
        "steady_glide_towards_folded_wing": bool(toward),
        "reaction_accel_mps2_per_rad_s2": float(reaction[0]),
        "reaction_pitch_accel_per_wing_accel": float(reaction[4]),
        "servo_accel_max_rad_s2": accel_max,
        "reaction_accel_peak_mps2": float(reaction[0] * accel_max),
        "reaction_displacement_m_per_rad": float(reaction[0]),
        "reaction_displacement_max_m": float(abs(reaction[0]) * stroke),
        "explanation": (
            "folding wing 1 up and wing 3 down by delta pushes the body %.3f N/rad towards wing 1 at the fall's "
            "%.3f m/s (drag and CG) and settles into a glide of %.3f m/s per rad; the thesis's inputs act only "
            "through the added-mass reaction, %.5f m/s^2 per rad/s^2 (%.3f m/s^2 at the servos' %.0f rad/s^2, "
            "only while the wing accelerates), which conserves momentum: a stroke moves the plate's centre %.2f mm "
            "per radian, away from the folded wing, and nothing more (%.1f mm over the whole +-%.0f deg travel, "
            "linearised; the body also turns, so its CG and CB move towards the folded wing: roboray-sim "
            "glide-check)"
            % (d_force[0], trim.descent_speed, v_per_rad, reaction[0], reaction[0] * accel_max, accel_max,
               reaction[0] * 1e3, abs(reaction[0]) * stroke * 1e3, math.degrees(stroke))),
    }
