"""On-board estimator: attitude, depth, vertical speed and horizontal
position from an IMU, a pressure sensor and delayed position fixes.

Board code: fixed-size, allocation-free steps, the same on CPython and
MicroPython. Parts, one module each:

- ``attitude``: Mahony complementary filter with gyro-bias estimation,
  accelerometer gated against feathering, tilt-compensated magnetometer
  heading;
- ``vertical``: depth / vertical speed / accelerometer-bias Kalman filter
  fusing pressure with the vertical specific force;
- ``horizontal``: dead reckoning with the descent model, corrected by
  delayed fixes through a history ring;
- ``descent_model``: the glide model's parameter table (one place);
- ``health``: health bits, time-outs and the layouts of the output arrays;
- ``estimator``: ``Estimator``, the composite the firmware calls.

Step API (``Estimator``; ticks are ``time.ticks_us()`` values, wrapping at
2**30; the estimator reads no clock):

``imu(t_us, gx, gy, gz, ax, ay, az)``
    gyro in rad/s and specific force in m/s^2, body axes (x along wing 1,
    z down when level), at 100 Hz. ``dt`` is the tick difference to the
    previous call (a gap over 0.25 s re-times without integrating). Fuses at
    most one pending sample (fix, else depth, else magnetometer), predicts,
    then writes every output.
``mag(t_us, mx, my, mz)``
    raw field in gauss, body axes, up to 100 Hz; calibrated inside
    (``set_mag_calibration``); ignored for ``servo_hold_s`` after a wing
    command changes.
``depth(t_us, pressure_pa)``
    absolute pressure in Pa, 25 Hz; ``t_us`` is the middle of the
    conversion. ``zero_depth(pressure_pa, depth_m)`` sets the surface.
``fix(t_us, north, east)``
    position of the centre of buoyancy in m (NED, the tracker's frame), 1 Hz;
    ``t_us`` is when it was measured, up to ``history`` IMU steps (0.64 s)
    before the latest ``imu()``.
``wings(s1, s2, s3, s4)``
    commanded wing angles in rad, whenever they change.
``check(t_us)``
    health against the caller's clock (the only way to see a silent IMU).

Promises (tests/test_estimator_*.py): at rest, within 1 deg of the truth
6 s after a 90 deg attitude error about any axis, and a 1 deg/s gyro bias
learned to 0.02 deg/s about the horizontal axes and 0.2 deg/s about the
vertical within 8 s; an outlier pressure, a wrong fix or a disturbed
magnetometer sample is rejected and counted, and four fixes in a row that
disagree restart the position on them; a silent sensor drops its health
bit within its time-out (``health.TIMEOUT_*_US``) plus 0.12 s.

Outputs, ``array`` objects made once and rewritten in place:
``q`` (4: body -> NED quaternion w, x, y, z), ``rates`` (3: bias-corrected,
rad/s), ``euler`` (3: roll, pitch, yaw, rad), ``nav`` (6: depth, vertical
speed, north, east, v_north, v_east; m, m/s, down positive), ``cov`` (9
variances, ``health.COV_*``), ``status`` (health bits, valid flag, rejection
counts; ``health.STATUS_*``), ``innovation`` (last test ratios).
"""

from roboray.shared.estimator.estimator import Estimator

__all__ = ["Estimator"]
