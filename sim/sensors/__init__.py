"""Sensor models driven by a ``Truth``: what the IMU (LSM6DSOX + LIS3MDL),
the depth sensor (MS5837-30BA) and the external position tracker report.

Each model is a function of a ``Truth``, a spec (datasheet figures and
stated assumptions, in its module) and a ``numpy`` random generator, and
returns a log of samples with their time stamps:

- ``imu.inertial`` -> ``InertialLog`` (gyro, accelerometer at 208 Hz);
- ``imu.magnetometer`` -> ``MagLog`` (155 Hz, with hard/soft iron, the
  servos' field, and the calibration an ellipsoid fit would give);
- ``depth.pressure`` -> ``PressureLog`` (25 Hz);
- ``position_fix.fixes`` -> ``FixLog`` (1 Hz, delayed, with dropouts).

``trajectory.descent`` generates a kinematically exact feathering descent
to drive them; ``noise`` holds the random processes and the statistics
(Allan deviation, spectral density) the tests check them with.
"""
