"""Sensors to the estimator: axes, calibration, time stamps, depth zero.

``Navigation`` owns the vehicle's ``Estimator`` (``shared/estimator``) and
feeds it from the drivers, as two scheduler tasks:

- ``step()`` (100 Hz): the IMU's FIFO (every sample since the last step:
  one in a normal step, four or five after a collection's stall), and
  every fourth step (25 Hz, the rate the estimator fuses it at:
  ``MAG_STEPS``) one magnetometer burst, mapped from the chips' axes to the
  body axes (x along wing 1, z down when level), then ``Estimator.imu`` /
  ``mag``. The IMU's samples reach the estimator as one step over the
  interval they cover, with their mean rate and specific force (the sums of
  their counts times the scale over their number: the delta-angle and
  delta-velocity of PX4's and ArduPilot's FIFO drivers): a stall costs the
  next step no more estimator work and boxes no float per sample. A failed
  IMU read still gives the estimator the time (``check``), which is how it
  notices a silent IMU (and coasts without it); a failed magnetometer read
  is tried again at the next step;
- ``depth_step()`` (every 20 ms): the MS5837 state machine; a fresh pressure
  goes to ``Estimator.depth`` with the middle of its conversion as its time.
  It also counts the pressures the estimator's gate rejected in a row
  (``depth_rejected_run``): a sensor that returns plausible-looking garbage,
  or sticks while the vehicle still moves, is caught there, by its
  disagreement with the accelerometer, never by a reading that stays the
  same (a vehicle resting on the bottom reads the same depth for minutes).
  Only refusals against a prediction the IMU drove count
  (``Estimator.depth_blamed``): while the estimator coasts without its
  IMU, a refusal says nothing about the depth sensor.

Position fixes (ATT_POS_MOCAP from the ground's tracker relay) arrive
through ``fix(north, east)``; the tracker's latency plus the radio's is the
``VISO_DELAY_MS`` parameter (ArduPilot's name for the same thing), so the
fix is dated ``now - VISO_DELAY_MS``, as ArduPilot dates external
navigation, and no clock has to be shared with the ground.

Mounting (``AHRS_ORIENTATION``, ArduPilot's numbering): 0 = chip axes are the
body axes; 8 = roll 180 deg (the default: the 9-DoF board lies flat with its
z up, the body's z points down); 2, 4, 6 and 10, 12, 14 add a yaw of 90,
180, 270 deg. The magnetometer shares the accelerometer's axes (one board).

The depth zero: ``BARO1_GND_PRESS`` (Pa) is the surface pressure the depth is
measured from. ``zero_at_surface()`` sets it from the latest pressure when
the vehicle is armed at the surface (the firmware calls it on arming, as
ArduPilot recalibrates its barometer on arming) and keeps it in the
parameter, so a board that resets under water still measures from the
surface; arming under water (estimated depth over 1 m) keeps it.
"""

from array import array

from roboray.firmware.drivers.health import FROZEN_SAMPLES
from roboray.firmware.drivers.lis3mdl import MAG_SCALE
from roboray.firmware.drivers.lsm6dsox import ACCEL_SCALE, GYRO_SCALE
from roboray.shared.estimator import Estimator
from roboray.shared.estimator.estimator import JOB_NONE
from roboray.shared.estimator import health as eh
from roboray.shared.estimator.attitude import Attitude
from roboray.shared.estimator.descent_model import from_params as descent_from_params
from roboray.shared.estimator.horizontal import Horizontal
from roboray.shared.params import DIVE_STATE, TYPE_REAL32, TYPE_UINT8, TYPE_UINT16

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_G = 9.80665
#: The magnetometer is read every this many steps (25 Hz), as often as the
#: estimator fuses it (``Estimator``'s ``mag_period_s``).
MAG_STEPS = const(4)
#: Scales kept for means of up to this many IMU samples (a collection's
#: stall leaves 4 or 5); more are scaled when they come (after a longer
#: stall), boxing six floats then.
_KN = const(8)
_WATER = 1000.0
_SURFACE_MAX_M = 1.0

#: Navigation parameters (shared/params.py declarations), ArduPilot's names where they exist.
PARAMS = (
    ("AHRS_ORIENTATION", TYPE_UINT8, 8, 0, 14),          # chip axes to body axes (0, 2, .. 14)
    # the reference vehicle (sim/vehicles/reference.py), from its centre of
    # buoyancy with the wings flat, 27.1 mm above the plate's centre
    ("INS_POS1_X", TYPE_REAL32, 0.010, -0.5, 0.5),      # m, IMU from the centre of buoyancy
    ("INS_POS1_Y", TYPE_REAL32, 0.005, -0.5, 0.5),
    ("INS_POS1_Z", TYPE_REAL32, -0.0029, -0.5, 0.5),
    ("BARO_POS_X", TYPE_REAL32, 0.0, -0.5, 0.5),        # m, pressure port from the centre of buoyancy
    ("BARO_POS_Y", TYPE_REAL32, 0.020, -0.5, 0.5),
    ("BARO_POS_Z", TYPE_REAL32, 0.0231, -0.5, 0.5),
    ("BARO_SPEC_GRAV", TYPE_REAL32, 1.0, 0.98, 1.05),   # water's specific gravity (1.0 fresh, 1.024 sea)
    ("BARO1_GND_PRESS", TYPE_REAL32, 101325.0, 50000.0, 120000.0, DIVE_STATE),  # Pa at the surface (set on arming)
    ("COMPASS_OFS_X", TYPE_REAL32, 0.0, -2000.0, 2000.0),  # mGauss, hard iron
    ("COMPASS_OFS_Y", TYPE_REAL32, 0.0, -2000.0, 2000.0),
    ("COMPASS_OFS_Z", TYPE_REAL32, 0.0, -2000.0, 2000.0),
    ("COMPASS_DIA_X", TYPE_REAL32, 1.0, 0.2, 5.0),      # soft iron, diagonal
    ("COMPASS_DIA_Y", TYPE_REAL32, 1.0, 0.2, 5.0),
    ("COMPASS_DIA_Z", TYPE_REAL32, 1.0, 0.2, 5.0),
    ("COMPASS_ODI_X", TYPE_REAL32, 0.0, -1.0, 1.0),     # soft iron, off-diagonal xy
    ("COMPASS_ODI_Y", TYPE_REAL32, 0.0, -1.0, 1.0),     # xz
    ("COMPASS_ODI_Z", TYPE_REAL32, 0.0, -1.0, 1.0),     # yz
    ("COMPASS_DEC", TYPE_REAL32, 0.0, -3.1416, 3.1416),  # rad, magnetic declination
    ("VISO_DELAY_MS", TYPE_UINT16, 210, 0, 2000),       # ms from a fix's measurement to its arrival
)

#: The position stays valid while its variance per axis is below this (m^2):
#: a 1-sigma of 0.5 m, the landing goal of a dive without fixes (issue 27).
#: A dive below the radio's reach dead-reckons from its last fix, and its
#: variance grows honestly (``shared/estimator/horizontal.py``): 0.04-0.07
#: m^2 at the bottom of a 10 m dive with none after release (the
#: estimator's own default, 0.0625, would have declared it invalid there
#: and the estimator failsafe put a TARGET dive into FAILSAFE mode for
#: what was planned). A start still needs a fix (the variance before one
#: is 100 m^2).
POSITION_VAR_MAX = 0.25

# AHRS_ORIENTATION -> where each body axis comes from in the chip's axes:
# (chip index, negate) for body x, y, z. Yaw 90 turns chip x onto body y.
_ROTATIONS = {
    0: ((0, 0), (1, 0), (2, 0)),
    2: ((1, 1), (0, 0), (2, 0)),
    4: ((0, 1), (1, 1), (2, 0)),
    6: ((1, 0), (0, 1), (2, 0)),
    8: ((0, 0), (1, 1), (2, 1)),
    10: ((1, 1), (0, 1), (2, 1)),
    12: ((0, 1), (1, 0), (2, 1)),
    14: ((1, 0), (0, 0), (2, 1)),
}

# Estimator.status bits the firmware reads
IMU_OK = eh.IMU_OK
ATTITUDE_VALID = eh.ATTITUDE_VALID
DEPTH_VALID = eh.DEPTH_VALID
POSITION_VALID = eh.POSITION_VALID

_HEALTH = eh.STATUS_HEALTH


def _p(params, name):
    i = params.index(name)
    if i < 0:
        raise ValueError("parameter %s is not declared" % name)
    return params.get(i)


class Navigation:
    """The estimator and its inputs.

    Parameters
    ----------
    imu, mag, depth:
        The LSM6DSOX, LIS3MDL and MS5837 drivers.
    params:
        The parameter table (``PARAMS`` above declared in it).
    clock:
        The ``time`` module (or the twin's virtual clock).

    Raises ValueError naming the parameter when one is unusable.
    """

    def __init__(self, imu, mag, depth, params, clock):
        self.imu = imu
        self.mag = mag
        self.depth = depth
        self.params = params
        self._clock = clock
        orientation = params.get_int(params.index("AHRS_ORIENTATION"))
        rot = _ROTATIONS.get(orientation)
        if rot is None:
            raise ValueError("AHRS_ORIENTATION %d is not supported (0, 2, 4, .. 14: yaw in 90 deg steps, "
                             "with or without roll 180)" % orientation)
        # Per body value (accel x y z, gyro x y z from the LSM6DSOX's ``sums``
        # [n_gyro, gx, gy, gz, n_accel, ax, ay, az]; field x y z from the
        # LIS3MDL's [temp, x, y, z]): the count it comes from, and the
        # counts-to-SI scale with the axis's sign. A value is then one
        # multiplication of a small integer: one boxed float, where scaling,
        # negating and copying through float arrays boxed two or three.
        self._raw_i = bytes([5 + rot[k][0] for k in range(3)] + [1 + rot[k][0] for k in range(3)]
                            + [1 + rot[k][0] for k in range(3)])
        self._scale = ([-ACCEL_SCALE if rot[k][1] else ACCEL_SCALE for k in range(3)]
                       + [-GYRO_SCALE if rot[k][1] else GYRO_SCALE for k in range(3)]
                       + [-MAG_SCALE if rot[k][1] else MAG_SCALE for k in range(3)])
        # the IMU's scales over n samples (the sums' mean), made once: a
        # mean costs a step what one sample does
        self._kn = [[k / n for k in self._scale[:6]] for n in range(1, _KN + 1)]
        self._kn.insert(0, self._scale[:6])
        self._kx = self._scale[:6]     # filled for a mean of more than _KN
        #: The last IMU and magnetometer sample in body axes: accel (m/s^2), gyro (rad/s), field (gauss).
        self.body = array("f", [0.0] * 9)
        self._mag_wait = 0
        # the magnetometer's frozen-output test over the same 0.2 s as at
        # 100 Hz (its own noise makes 5 exact repeats in a row impossible)
        mag.health.frozen_samples = FROZEN_SAMPLES // MAG_STEPS
        self._gnd = params.index("BARO1_GND_PRESS")
        self._delay_i = params.index("VISO_DELAY_MS")
        density = _WATER * _p(params, "BARO_SPEC_GRAV")
        descent = descent_from_params(params)
        self.est = Estimator(
            attitude=Attitude(declination=_p(params, "COMPASS_DEC")),
            horizontal=Horizontal(tau=descent.tau_s), descent=descent,
            imu_position=(_p(params, "INS_POS1_X"), _p(params, "INS_POS1_Y"), _p(params, "INS_POS1_Z")),
            port_position=(_p(params, "BARO_POS_X"), _p(params, "BARO_POS_Y"), _p(params, "BARO_POS_Z")),
            fluid_density=density, surface_pressure_pa=params.get(self._gnd),
            mag_period_s=MAG_STEPS * 0.01, position_var_max=POSITION_VAR_MAX)
        self._rho_g = density * _G
        self.configure_compass()
        self.imu_samples = 0
        self.depth_samples = 0
        self.fixes = 0
        #: Fresh pressures the estimator's gate rejected in a row.
        self.depth_rejected_run = 0
        self._rejects_seen = 0
        self._used_seen = 0
        self._running = False
        self._fed = False

    def configure_compass(self):
        """Magnetometer calibration from the COMPASS_* parameters (mGauss offsets)."""
        p = self.params
        o = (_p(p, "COMPASS_OFS_X") * 0.001, _p(p, "COMPASS_OFS_Y") * 0.001, _p(p, "COMPASS_OFS_Z") * 0.001)
        dx, dy, dz = _p(p, "COMPASS_DIA_X"), _p(p, "COMPASS_DIA_Y"), _p(p, "COMPASS_DIA_Z")
        xy, xz, yz = _p(p, "COMPASS_ODI_X"), _p(p, "COMPASS_ODI_Y"), _p(p, "COMPASS_ODI_Z")
        # ArduPilot's soft-iron matrix: symmetric, diagonal DIA, off-diagonal ODI.
        self.est.set_mag_calibration(o, (dx, xy, xz, xy, dy, yz, xz, yz, dz))

    # ------------------------------------------------------------ tasks
    def step(self):
        """Scheduler task (100 Hz): the IMU to the estimator, and every
        ``MAG_STEPS``-th call the magnetometer."""
        est = self.est
        t = self._clock.ticks_us()
        i = self._raw_i
        k = self._scale
        # Straight-line: a loop or a helper call per axis costs more than the
        # arithmetic on MicroPython.
        imu = self.imu
        b = self.body
        if not self._running:
            # the first step: what the IMU batched while the board was set
            # up (tens of ms) is old, and reading it would cost this slot
            # ~4 ms of I2C; the estimator starts from the next sample
            self._running = True
            imu.discard()
            est.check(t)
            return
        if imu.read():
            r = imu.sums
            n = r[4]
            ka = self._kn[n] if n <= _KN else self._mean_scale(n)
            ax = r[i[0]] * ka[0]
            ay = r[i[1]] * ka[1]
            az = r[i[2]] * ka[2]
            n = r[0]
            self.imu_samples += n
            kg = self._kn[n] if n <= _KN else self._mean_scale(n)
            gx = r[i[3]] * kg[3]
            gy = r[i[4]] * kg[4]
            gz = r[i[5]] * kg[5]
            b[0] = ax
            b[1] = ay
            b[2] = az
            b[3] = gx
            b[4] = gy
            b[5] = gz
            est.imu(t, gx, gy, gz, ax, ay, az)
        else:
            est.check(t)
        # Due, the magnetometer waits (two steps at most) for a step in
        # which the estimator had no job (``Estimator.job``): no step then
        # carries both its burst and one of the dearer jobs.
        n = self._mag_wait - 1
        if n > 0 or (n > -2 and est.job != JOB_NONE):
            self._mag_wait = n
            return
        mag = self.mag
        if mag.read():
            self._mag_wait = MAG_STEPS
            r = mag.raw
            mx = r[i[6]] * k[6]
            my = r[i[7]] * k[7]
            mz = r[i[8]] * k[8]
            b[6] = mx
            b[7] = my
            b[8] = mz
            est.mag(t, mx, my, mz)
        else:
            self._mag_wait = 1    # try again next step

    def _mean_scale(self, n):
        # the scales over n samples, in the one spare list (after a long stall)
        k = self._scale
        x = self._kx
        for j in range(6):
            x[j] = k[j] / n
        return x

    def depth_step(self):
        """Scheduler task (every 20 ms): the pressure sensor to the estimator."""
        est = self.est
        if self._fed:
            # the estimator fused (or refused) the previous pressure by now
            rejects = est.depth_blamed
            used = est.depth_used
            if rejects != self._rejects_seen:
                self._rejects_seen = rejects
                self.depth_rejected_run += 1
            elif used != self._used_seen:
                self.depth_rejected_run = 0
            # neither: too old to fuse (a stall), or refused while the
            # estimator coasted; the run neither grows nor ends
            self._used_seen = used
            self._fed = False
        d = self.depth
        if d.update():
            est.depth(d.sample_us, d.pressure_pa)
            self.depth_samples += 1
            self._fed = True

    def fix(self, north, east):
        """A position fix (m, NED) that arrived now; dated by VISO_DELAY_MS."""
        clock = self._clock
        delay_us = self.params.get_int(self._delay_i) * 1000
        self.est.fix(clock.ticks_add(clock.ticks_us(), -delay_us), north, east)
        self.fixes += 1

    # ------------------------------------------------------------ state
    def valid(self, bits):
        """True when every estimator status bit in ``bits`` is set."""
        return self.est.status[_HEALTH] & bits == bits

    def depth_m(self):
        return self.est.nav[0]

    def zero_at_surface(self):
        """Take the latest pressure as the surface's (on arming); True if done."""
        d = self.depth
        if not d.health.healthy():
            return False
        if self.valid(DEPTH_VALID) and self.est.nav[0] > _SURFACE_MAX_M:
            return False  # armed under water: keep the surface we had
        p = d.pressure_pa
        est = self.est
        est.zero_depth(p, 0.0)
        # restart the depth filter on the new zero, as Estimator.reset() does,
        # rather than let its gate refuse a jump it did not see happen
        est.vert.initialised = False
        self.depth_rejected_run = 0
        self.params.set(self._gnd, float(p))
        return True
