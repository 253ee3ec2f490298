"""What the estimator tells the failsafes: health bits, validity, layouts.

``Estimator.status`` (``array('i')``):

- ``status[STATUS_HEALTH]``: bit set of the ``*_OK`` sensor flags, the
  ``*_VALID`` estimate flags and a few diagnostic bits;
- ``status[STATUS_VALID]``: 1 when attitude, depth and position are all
  valid, else 0;
- ``status[STATUS_*_REJECTS]``: samples the gates rejected so far.

A sensor's flag is set while its last usable sample is younger than its
time-out (``TIMEOUT_*_US``). The flags are evaluated by the estimator's
10 Hz housekeeping, so one drops at most 0.12 s after its time-out expires
(the housekeeping yields up to two steps to a pending fix or depth sample),
or at once when the caller's own clock is given to ``Estimator.check()``
(the only way to notice a silent IMU).
"""

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

# sensors
IMU_OK = const(0x001)
MAG_OK = const(0x002)
DEPTH_OK = const(0x004)
FIX_OK = const(0x008)
# estimates
ATTITUDE_VALID = const(0x010)
DEPTH_VALID = const(0x020)
POSITION_VALID = const(0x040)
# diagnostics
ACCEL_USED = const(0x080)      # the last IMU step used the accelerometer
SERVOS_MOVING = const(0x100)   # magnetometer ignored while the wing servos draw current
FAST_ALIGN = const(0x200)      # start-up gains in use

#: Default time-outs, microseconds.
TIMEOUT_IMU_US = const(50000)
TIMEOUT_MAG_US = const(250000)
TIMEOUT_DEPTH_US = const(250000)
TIMEOUT_FIX_US = const(3000000)

# layout of Estimator.status
STATUS_HEALTH = const(0)
STATUS_VALID = const(1)
STATUS_MAG_REJECTS = const(2)
STATUS_DEPTH_REJECTS = const(3)
STATUS_FIX_REJECTS = const(4)
STATUS_SIZE = const(5)

# layout of Estimator.nav
NAV_DEPTH = const(0)     # m, centre of buoyancy, down positive
NAV_VZ = const(1)        # m/s, down positive
NAV_NORTH = const(2)     # m
NAV_EAST = const(3)      # m
NAV_VN = const(4)        # m/s
NAV_VE = const(5)        # m/s
NAV_SIZE = const(6)

# layout of Estimator.cov (variances, SI units squared)
COV_TILT = const(0)       # rad^2, attitude error about a horizontal axis (model of the filter loop)
COV_HEADING = const(1)    # rad^2, error about the vertical (same)
COV_DEPTH = const(2)      # m^2
COV_VZ = const(3)         # (m/s)^2
COV_ACCEL_BIAS = const(4)  # (m/s^2)^2, vertical accelerometer bias
COV_NORTH = const(5)      # m^2
COV_EAST = const(6)       # m^2
COV_VN = const(7)         # (m/s)^2, velocity bias (current + model error)
COV_VE = const(8)         # (m/s)^2
COV_SIZE = const(9)

# layout of Estimator.innovation: last test ratio y^2 / (gate^2 S); > 1 rejected
INNOV_MAG = const(0)
INNOV_DEPTH = const(1)
INNOV_FIX = const(2)
INNOV_SIZE = const(3)
