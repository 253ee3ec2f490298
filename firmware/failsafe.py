"""Failsafes and arming checks, named and shaped after ArduSub's.

Every failsafe is a condition the firmware watches, an action taken once
when the condition appears, and a report: a STATUSTEXT when it appears
(repeated every 10 s while it lasts, as ArduSub repeats its leak warning)
and when it clears (a failed sensor has to stay sound for 3 s first, so
one that fails now and then does not make it flap), and its bit in SYS_STATUS ``errors_count1``
(``Telemetry.failsafe_flags``; bit ``i`` is failsafe ``i`` below).

Actions (one code set for all, ArduSub's where it has one):
0 off (not even reported), 1 warn (report only), 2 disarm, 3 FAILSAFE mode
(hold the safe wing configuration ``FS_WING_DEG``; our counterpart of
ArduSub's SURFACE, whose number it has). An action applies once, when the
condition appears (an event, as ArduPilot's failsafes), and only while
armed: disarmed, the servos are at the safe position already and the
arming checks refuse what would be unsafe (ArduSub warns of a leak on deck
and acts only armed). A vehicle armed again by a resume after a reset
(``firmware/resume.py``: no arming by the operator) gets the actions of
the failsafes active then: the dive they would have acted on goes on.

Leaving FAILSAFE: the operator may select any mode once the failsafes that
switched to it have cleared (``failsafe_held()``, for ``shared/modes.py``:
while one is active a request is refused, and a "FAILSAFE held: ..."
STATUSTEXT names it); disarming is always allowed. A failsafe that only
warns holds nothing, and the operator is never overridden while a
condition lasts: only its next appearance acts again.

====  ===============  ===============================================  =====================  =======
bit   failsafe         condition                                        parameters             default
====  ===============  ===============================================  =====================  =======
0     link lost        no ground heartbeat for FS_GCS_TIMEOUT s, after  FS_GCS_ENABLE,         warn
                       one was seen (ArduSub's GCS failsafe), while no  FS_GCS_TIMEOUT,
                       deeper than FS_GCS_DEPTH (below)                 FS_GCS_DEPTH
1     leak             the leak probe, debounced and latched            FS_LEAK_ENABLE         FAILSAFE
2     battery low      pack below BATT_LOW_VOLT for BATT_LOW_TIMER s    BATT_FS_LOW_ACT        warn
3     estimator        armed and an estimate the mode needs (attitude,  FS_EKF_ACTION,         FAILSAFE
                       depth; position in VELOCITY and TARGET) invalid  FS_EKF_THRESH
                       for 1 s, or two of the three innovation test
                       ratios (compass, depth, fix) above FS_EKF_THRESH;
                       not while the IMU failsafe acts (its cause)
4     depth sensor     driver unhealthy (bus errors, CRC, impossible    FS_SENSOR_ACT          FAILSAFE
                       values, no fresh conversion), or 8 pressures in
                       a row refused by the estimator (garbage, or
                       stuck while the accelerometer says it moves;
                       refusals while it coasts without its IMU do not
                       count), which lasts until the next arming: the
                       estimator takes a stuck reading back in after a
                       while
5     IMU              accelerometer/gyroscope driver unhealthy         FS_SENSOR_ACT          FAILSAFE
6     compass          magnetometer driver unhealthy                    FS_MAG_ACT             warn
7     max depth        estimated depth beyond FS_DEPTH_MAX (0: off)     FS_DEPTH_ACT           warn
8     loop overruns    FS_LOOP_MAX or more overrun slots in a second    FS_LOOP_ACT            warn
9     watchdog reset   the board came up from a watchdog reset (the     FS_LOCKUP_ACT          warn
                       loop locked up); lasts until the next arming
10    battery monitor  the voltage divider reads at a rail (no pack,    BATT_FS_LOW_ACT        warn
                       open or shorted divider)
====  ===============  ===============================================  =====================  =======

The link expected lost (issue 27): radio barely crosses water (the
buildable vehicle's 433 MHz HC-12 holds its link to ~5 m in fresh water,
~0.1 m in the sea: ``roboray-sim radio-reach``), so a dive below that is
planned without the link: everything it needs (mode, target, mission) is on
board before release, and the estimate dead-reckons. A link lost while the
estimated depth is beyond ``FS_GCS_DEPTH`` is therefore no failsafe: its
bit stays clear and nothing acts; the vehicle says "link lost below N m,
expected" once (a warning), as it goes below FS_GCS_DEPTH armed (while
the link still carries it to the operator) or, if it had not, when it
finds the link gone there, and "link regained" when a ground heartbeat
arrives again (telemetry, fixes and commands then resume by themselves:
the endpoint never stopped sending, and answers the returning ground
station's heartbeat at once). Shallower than FS_GCS_DEPTH a lost link is
the failsafe as before, and once that has acted it holds until the link
is back, whatever the depth. In salt water (``BARO_SPEC_GRAV`` above
``SALT_SPEC_GRAV``, which the builder sets for the sea) FS_GCS_DEPTH counts
as at most ``SEA_REACH_M``: at 4-5 S/m every radio's reach is a
decimetre or so (``roboray-sim radio-reach --water sea``: 0.11 m for the
HC-12 and the 915 MHz SiK, 0.14 m for the 433 MHz SiK), so a sea dive
needs no change of FS_GCS_DEPTH from the fresh-water default.

A sensor's condition (depth, IMU, compass, battery monitor) counts once
its driver has read unhealthy for ``SENSOR_CONFIRM_MS`` (200 ms) in a row:
the slots after a planned stall (a flash save, up to 150 ms) read stale
with nothing wrong.

No sensor is failed for a reading that stays the same: a vehicle resting on
the bottom reads the same depth, attitude and field for as long as it
rests, and that raises nothing. A lock-up itself is the scheduler's to
catch (it stops feeding the watchdog); this module reports it after the
reset and applies FS_LOCKUP_ACT once the board is armed again (3: a dive
resumed after the reset goes on in FAILSAFE mode).

Arming checks (``arming_check()``, for ``shared/modes.py``, which then
checks the mode it arms in; ``ARMING_CHECK`` 0 skips them): no leak, IMU, depth sensor and compass healthy, battery not
low and its monitor working, attitude and depth estimates valid. Mode checks
(``mode_check(mode)``): ATTITUDE, VELOCITY and TARGET need a controller in
the firmware and a valid attitude; VELOCITY and TARGET a valid position;
TARGET a target (armed in TARGET without one: "PreArm: TARGET mode has no
target", the dive must not leave without it). A refusal returns a ``shared/modes.py`` reason (sent in
COMMAND_ACK and as a STATUSTEXT); details beyond those reasons go out as a
"PreArm: ..." STATUSTEXT first, as ArduPilot words them.

``update()`` runs at 10 Hz and allocates nothing once the texts are built.
"""

from roboray.firmware import navigation as nv
from roboray.shared import modes as M
from roboray.shared.mavlink import messages as msg
from roboray.shared.params import TYPE_REAL32, TYPE_UINT8, TYPE_UINT16

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

LINK = const(0)
LEAK = const(1)
BATTERY = const(2)
EKF = const(3)
DEPTH = const(4)
IMU = const(5)
COMPASS = const(6)
MAX_DEPTH = const(7)
OVERRUN = const(8)
LOCKUP = const(9)
BATT_MONITOR = const(10)
COUNT = const(11)

#: Name of each failsafe, by bit.
NAMES = ("link lost", "leak", "battery low", "estimator", "depth sensor", "IMU", "compass", "max depth",
         "loop overruns", "watchdog reset", "battery monitor")
#: The parameter holding each failsafe's action, by bit.
ACTION_PARAMS = ("FS_GCS_ENABLE", "FS_LEAK_ENABLE", "BATT_FS_LOW_ACT", "FS_EKF_ACTION", "FS_SENSOR_ACT",
                 "FS_SENSOR_ACT", "FS_MAG_ACT", "FS_DEPTH_ACT", "FS_LOOP_ACT", "FS_LOCKUP_ACT", "BATT_FS_LOW_ACT")

ACT_OFF = const(0)
ACT_WARN = const(1)
ACT_DISARM = const(2)
ACT_FAILSAFE = const(3)
#: What each action does, as the reports say it.
ACTIONS = ("off", "warning", "disarmed", "FAILSAFE mode")

#: Failsafe parameters beyond ``shared/param_defs.py``'s (declarations).
PARAMS = (
    ("BATT_LOW_TIMER", TYPE_REAL32, 10.0, 0.0, 120.0),  # s below BATT_LOW_VOLT before it counts
    ("FS_SENSOR_ACT", TYPE_UINT8, 3, 0, 3),             # IMU or depth sensor failed
    ("FS_MAG_ACT", TYPE_UINT8, 1, 0, 3),                # compass failed
    ("FS_DEPTH_MAX", TYPE_REAL32, 20.0, 0.0, 300.0),    # m, deepest allowed (0: off)
    ("FS_DEPTH_ACT", TYPE_UINT8, 1, 0, 3),
    ("FS_LOOP_MAX", TYPE_UINT16, 10, 1, 100),           # overrun slots in a second that count
    ("FS_LOOP_ACT", TYPE_UINT8, 1, 0, 3),
    ("FS_LOCKUP_ACT", TYPE_UINT8, 1, 0, 3),             # after a watchdog reset
    ("BATT_PARK", TYPE_UINT8, 1, 0, 1),                 # 1: servos parked while disarmed with a low pack
)

GRACE_MS = const(2000)      # after start-up: drivers and estimator find their feet
HOLD_MS = const(3000)       # a failsafe clears only after its condition has been gone this long
REPEAT_MS = const(10000)    # an active failsafe's report is repeated this often
EKF_DELAY_MS = const(1000)
OVERRUN_WINDOW_MS = const(1000)
DEPTH_REJECTED_MAX = const(8)
#: A sensor's driver must read unhealthy this long before its failsafe
#: counts it. A planned stall (a flash save announces up to 150 ms,
#: ``flash_record.SAVE_STALL_MS``) leaves the IMU's FIFO past what one read
#: takes and every driver's last sample older than its time-out, so the
#: slot or two after it read unhealthy with nothing wrong; acting on that
#: put a healthy vehicle into FAILSAFE mode at a TARGET entry's save. A part
#: that is really gone stays gone: 200 ms is two evaluations at 10 Hz, and
#: the estimator coasts over it (ArduPilot likewise waits before its sensor
#: and EKF failsafes act).
SENSOR_CONFIRM_MS = const(200)

_PARKED = "Battery low: servos parked (disarmed)"
_UNPARKED = "Servos unparked"

# Why FAILSAFE mode was entered (Modes.failsafe_cause), by bit.
_CAUSES = (M.CHECK_FAILED, M.LEAK, M.LOW_BATTERY, M.CHECK_FAILED, M.SENSOR_FAULT, M.SENSOR_FAULT,
           M.SENSOR_FAULT, M.CHECK_FAILED, M.CHECK_FAILED, M.CHECK_FAILED, M.SENSOR_FAULT)

# MAV_SYS_STATUS_SENSOR bits
S_GYRO = const(0x1)
S_ACCEL = const(0x2)
S_MAG = const(0x4)
S_PRESSURE = const(0x8)
S_VISION = const(0x80)
S_MOTORS = const(0x8000)
S_AHRS = const(0x200000)
S_BATTERY = const(0x2000000)
S_PREARM = const(0x10000000)
SENSORS_PRESENT = S_GYRO | S_ACCEL | S_MAG | S_PRESSURE | S_VISION | S_MOTORS | S_AHRS | S_BATTERY | S_PREARM

_ATT_DEPTH = nv.ATTITUDE_VALID | nv.DEPTH_VALID
_ARM_ATTITUDE = nv.ATTITUDE_VALID | nv.IMU_OK
_ALL_VALID = nv.ATTITUDE_VALID | nv.DEPTH_VALID | nv.POSITION_VALID
# Conditions that clear at once (their own time-out or latch decides), the
# rest are held for HOLD_MS so a sensor that fails now and then does not
# make the failsafe flap.
_NO_HOLD = (1 << LINK) | (1 << LEAK) | (1 << LOCKUP)
# Conditions read from a driver's health, confirmed over SENSOR_CONFIRM_MS.
_SENSORS = (DEPTH, IMU, COMPASS, BATT_MONITOR)
_ARM_BLOCKERS = (1 << LEAK) | (1 << IMU) | (1 << DEPTH) | (1 << COMPASS) | (1 << BATTERY) | (1 << BATT_MONITOR)

_PREARM_DEPTH = "PreArm: no depth estimate yet"
_PREARM_EKF = "PreArm: estimator inconsistent"
_NO_CONTROLLER = "no controller in this firmware"
_PREARM_TARGET = "PreArm: TARGET mode has no target"
_LINK_REGAINED = "link regained"
#: Specific gravity above which the water is taken for salt (brackish water
#: of ~13 g/kg salinity, 1.01, already conducts ~2 S/m), and the depth to
#: which a radio then reaches at most (m; see the module docstring).
SALT_SPEC_GRAV = 1.01
SEA_REACH_M = 0.1


def _ticks_diff(a, b):
    return ((a - b + 0x20000000) & 0x3FFFFFFF) - 0x20000000


class Failsafes:
    """The failsafes and the arming checks of one vehicle.

    Parameters
    ----------
    params:
        The parameter table (``PARAMS`` and ``shared/param_defs.py``'s
        FAILSAFE group declared).
    nav:
        ``firmware.navigation.Navigation`` (estimator, IMU, compass, depth).
    leak, battery:
        The leak and battery drivers.
    sched:
        The ``Scheduler`` (overrun counts); may be set after construction.
    clock:
        The ``time`` module.
    watchdog_reset:
        True when the board came up from a watchdog reset.

    ``modes`` (``shared/modes.Modes``), ``link`` (anything with
    ``gcs_last_ms``, ``now_ms`` and ``send_text(severity, text)``: the
    MAVLink endpoint) and ``has_controller`` are set by the application
    once those exist. Attributes: ``raw`` (every condition, bit set),
    ``active`` (those with an action other than off: what is reported),
    ``triggered`` (count per failsafe), ``sensors_health`` (MAV_SYS_STATUS
    bits).
    """

    def __init__(self, params, nav, leak, battery, sched, clock, watchdog_reset=False):
        self.params = params
        self.nav = nav
        self.leak = leak
        self.battery = battery
        self.sched = sched
        self.modes = None
        self.link = None
        self.telemetry = None
        self.has_controller = False
        self._clock = clock
        self.raw = 0
        self.active = 0
        self.triggered = [0] * COUNT
        self.sensors_health = 0
        self._lockup = watchdog_reset
        self._t0 = clock.ticks_ms()
        self._act_i = bytearray(COUNT)
        for i in range(COUNT):
            j = params.index(ACTION_PARAMS[i])
            if j < 0:
                raise ValueError("parameter %s is not declared" % ACTION_PARAMS[i])
            self._act_i[i] = j
        self._i_gcs_timeout = params.index("FS_GCS_TIMEOUT")
        self._i_gcs_depth = params.index("FS_GCS_DEPTH")
        if self._i_gcs_depth < 0:
            raise ValueError("parameter FS_GCS_DEPTH is not declared")
        self._i_spec_grav = params.index("BARO_SPEC_GRAV")   # -1: not in this table (fresh water)
        self._gcs_depth = 0.0                                # FS_GCS_DEPTH, capped in salt water
        self._i_low_volt = params.index("BATT_LOW_VOLT")
        self._i_low_timer = params.index("BATT_LOW_TIMER")
        self._i_park = params.index("BATT_PARK")
        #: The servos are parked (``Flight`` sends them no pulses): the pack
        #: is low (BATT_LOW_VOLT for BATT_LOW_TIMER, whatever its action),
        #: the vehicle disarmed and BATT_PARK 1. A vehicle left on the
        #: bottom disarmed otherwise spends the pack holding flat wings
        #: that rest on the bottom anyway; parked, each servo draws only
        #: its idle current and the cells last until the vehicle is
        #: recovered (docs/user/hardware.md, "Electrical safety"). Arming
        #: gives the servos their pulses back (the arming check refuses a
        #: low pack anyway).
        self.parked = False
        self._i_ekf_thresh = params.index("FS_EKF_THRESH")
        self._i_depth_max = params.index("FS_DEPTH_MAX")
        self._i_loop_max = params.index("FS_LOOP_MAX")
        self._i_arming = params.index("ARMING_CHECK")
        # Report texts, built once: [failsafe][action], cleared, by bit.
        self._texts = []
        self._cleared = []
        for i in range(COUNT):
            self._texts.append(tuple("Failsafe: %s, %s" % (NAMES[i], ACTIONS[a]) for a in range(4)))
            self._cleared.append("Failsafe cleared: %s" % NAMES[i])
        self._said = bytearray(COUNT)   # the action last reported, per failsafe
        self._version = -1
        self._enabled = 0
        self._low_since = -1
        self._ekf_since = -1
        self._ekf_need = _ATT_DEPTH
        self._overrun_t = self._t0
        self._overrun_n = 0
        self._overrun_hot = False
        self._repeat_t = self._t0
        self._repeat_i = 0
        self._seen_ms = [0] * COUNT   # when each condition was last true
        self._bad_ms = [-1] * COUNT   # since when each sensor has read unhealthy (-1: it does not)
        self._depth_implausible = False
        self._holding = 0             # failsafes that switched to FAILSAFE mode, by bit
        self._held_texts = tuple("FAILSAFE held: %s" % NAMES[i] for i in range(COUNT))
        self._armed = False           # armed at the last update
        self._arms = 0                # the operator's armings seen at the last update
        self._deep_text = ""          # "link lost below N m, expected" (built with the parameters)
        self._deep = False            # deeper than FS_GCS_DEPTH at the last update
        self._deep_said = False       # and it has been said since the vehicle went below it
        self._link_expected = False   # the link is lost, deeper than FS_GCS_DEPTH: no failsafe

    def action(self, i):
        """The configured action of failsafe ``i`` (``ACT_*``)."""
        return self.params.get_int(self._act_i[i])

    def _load(self):
        self._version = self.params.version
        mask = 0
        for i in range(COUNT):
            if self.action(i) != ACT_OFF:
                mask |= 1 << i
        self._enabled = mask
        p = self.params
        d = p.get(self._i_gcs_depth)
        if self._i_spec_grav >= 0 and p.get(self._i_spec_grav) > SALT_SPEC_GRAV and d > SEA_REACH_M:
            d = SEA_REACH_M
        self._gcs_depth = d
        self._deep_text = "link lost below %g m, expected" % d

    # ---------------------------------------------------------- conditions
    def _conditions(self, now):
        p = self.params
        nav = self.nav
        est = nav.est
        c = 0
        link = self.link
        if link is not None and link.gcs_last_ms >= 0:
            timeout = p.get(self._i_gcs_timeout) * 1000.0
            if _ticks_diff(link.now_ms, link.gcs_last_ms) > timeout:
                c |= 1 << LINK
        if self.leak.detected:
            c |= 1 << LEAK
        bat = self.battery
        if not bat.health.healthy():
            c |= 1 << BATT_MONITOR
            self._low_since = -1
        elif bat.volts[0] < p.get(self._i_low_volt):
            if self._low_since < 0:
                self._low_since = now
            if _ticks_diff(now, self._low_since) >= p.get(self._i_low_timer) * 1000.0:
                c |= 1 << BATTERY
        else:
            self._low_since = -1
        if nav.depth_rejected_run >= DEPTH_REJECTED_MAX:
            self._depth_implausible = True
        if not nav.depth.health.healthy() or self._depth_implausible:
            c |= 1 << DEPTH
        if not nav.imu.health.healthy():
            c |= 1 << IMU
        if not nav.mag.health.healthy():
            c |= 1 << COMPASS
        depth_max = p.get(self._i_depth_max)
        if depth_max > 0.0 and nav.valid(nv.DEPTH_VALID) and est.nav[0] > depth_max:
            c |= 1 << MAX_DEPTH
        # An estimate the IMU's failure leaves invalid is the IMU failsafe's
        # to act on while it acts (FAILSAFE mode or disarm, and the 3 s it is
        # held after the IMU recovers): one cause, one failsafe. When it only
        # warns, FS_EKF_ACTION acts on the estimate.
        if (c | self.active) & (1 << IMU) and self.action(IMU) >= ACT_DISARM:
            self._ekf_since = -1
        elif self._ekf_bad(now):
            c |= 1 << EKF
        sched = self.sched
        if sched is not None and _ticks_diff(now, self._overrun_t) >= OVERRUN_WINDOW_MS:
            self._overrun_t = now
            n = sched.overruns
            self._overrun_hot = n - self._overrun_n >= p.get_int(self._i_loop_max)
            self._overrun_n = n
        if self._overrun_hot:
            c |= 1 << OVERRUN
        if self._lockup:
            c |= 1 << LOCKUP
        return self._confirmed(c, now)

    def _confirmed(self, c, now):
        """``c`` with each sensor's bit kept only once it has been set for
        SENSOR_CONFIRM_MS in a row (a stall's aftermath is not a fault)."""
        bad = self._bad_ms
        for i in _SENSORS:
            bit = 1 << i
            if c & bit:
                if bad[i] < 0:
                    bad[i] = now
                if _ticks_diff(now, bad[i]) < SENSOR_CONFIRM_MS and not self.active & bit:
                    c &= ~bit
            else:
                bad[i] = -1
        return c

    def _ekf_bad(self, now):
        modes = self.modes
        if modes is None or not modes.armed:
            self._ekf_since = -1
            return False
        if not (self.active >> EKF) & 1:
            # the estimates this mode needs; kept while the failsafe lasts, so
            # leaving TARGET for FAILSAFE does not clear it by itself
            mode = modes.mode
            need = _ATT_DEPTH
            if mode == M.VELOCITY or mode == M.TARGET:
                need = _ALL_VALID
            self._ekf_need = need
        nav = self.nav
        bad = not nav.valid(self._ekf_need)
        if not bad:
            inn = nav.est.innovation
            thresh = self.params.get(self._i_ekf_thresh)
            n = 0
            for k in range(3):
                if inn[k] > thresh:
                    n += 1
            bad = n >= 2
        if not bad:
            self._ekf_since = -1
            return False
        if self._ekf_since < 0:
            self._ekf_since = now
        return _ticks_diff(now, self._ekf_since) >= EKF_DELAY_MS

    # -------------------------------------------------------------- update
    def update(self):
        """Evaluate every failsafe; act and report on changes (10 Hz)."""
        now = self._clock.ticks_ms()
        if self.params.version != self._version:
            self._load()
        self._health_bits()
        if _ticks_diff(now, self._t0) < GRACE_MS:
            return
        raw = self._expected(self._conditions(now))
        self.raw = raw
        held = raw
        seen = self._seen_ms
        for i in range(COUNT):
            bit = 1 << i
            if raw & bit:
                seen[i] = now
            elif self.active & bit and not _NO_HOLD & bit and _ticks_diff(now, seen[i]) < HOLD_MS:
                held |= bit
        active = held & self._enabled
        rising = active & ~self.active
        modes = self.modes
        if modes is not None:
            if modes.armed and not self._armed and modes.arms == self._arms:
                rising = active   # resumed armed after a reset: what is active acts now
            self._armed = modes.armed
            self._arms = modes.arms
        falling = self.active & ~active
        self.active = active
        if rising:
            self._repeat_t = now
            for i in range(COUNT):
                if (rising >> i) & 1:
                    self._trigger(i)
        if falling:
            for i in range(COUNT):
                if (falling >> i) & 1:
                    self._say(msg.MAV_SEVERITY_NOTICE, self._cleared[i])
        if active and _ticks_diff(now, self._repeat_t) >= REPEAT_MS:
            self._repeat_t = now
            for _ in range(COUNT):
                i = self._repeat_i
                self._repeat_i = i + 1 if i + 1 < COUNT else 0
                if (active >> i) & 1:
                    a = self._said[i]
                    self._say(msg.MAV_SEVERITY_WARNING if a <= ACT_WARN else msg.MAV_SEVERITY_CRITICAL,
                              self._texts[i][a])
                    break
        park = bool((raw >> BATTERY) & 1) and not self._armed and self.params.get_int(self._i_park) == 1
        if park != self.parked:
            self.parked = park
            self._say(msg.MAV_SEVERITY_WARNING if park else msg.MAV_SEVERITY_NOTICE,
                      _PARKED if park else _UNPARKED)
        t = self.telemetry
        if t is not None:
            t.failsafe_flags = active

    def _expected(self, raw):
        """``raw`` without the link's bit while its loss is expected (deeper
        than FS_GCS_DEPTH, the failsafe not acting already); says so once,
        and says when the link is back."""
        nav = self.nav
        deep = nav.valid(nv.DEPTH_VALID) and nav.est.nav[0] > self._gcs_depth
        armed = self.modes is not None and self.modes.armed
        if deep and not self._deep and armed and not self._deep_said:
            # going below it: told while the link still carries it
            self._deep_said = True
            self._say(msg.MAV_SEVERITY_WARNING, self._deep_text)
        elif not deep:
            self._deep_said = False
        self._deep = deep
        if raw & (1 << LINK):
            if deep and not self.active & (1 << LINK):
                if not self._link_expected:
                    self._link_expected = True
                    if not self._deep_said:
                        self._deep_said = True
                        self._say(msg.MAV_SEVERITY_WARNING, self._deep_text)
                return raw & ~(1 << LINK)
            self._link_expected = False
        elif self._link_expected:
            self._link_expected = False
            self._deep_said = False
            self._say(msg.MAV_SEVERITY_NOTICE, _LINK_REGAINED)
        return raw

    def _trigger(self, i):
        self.triggered[i] += 1
        act = self.action(i)
        modes = self.modes
        done = ACT_WARN
        if modes is not None:
            if act == ACT_DISARM and modes.armed:
                modes.disarm()
                done = ACT_DISARM
            elif act == ACT_FAILSAFE and modes.armed:
                if modes.mode != M.FAILSAFE:
                    modes.failsafe(_CAUSES[i])
                self._holding |= 1 << i
                done = ACT_FAILSAFE
        self._said[i] = done
        self._say(msg.MAV_SEVERITY_WARNING if done == ACT_WARN else msg.MAV_SEVERITY_CRITICAL,
                  self._texts[i][done])

    def _say(self, severity, text):
        link = self.link
        if link is not None:
            link.send_text(severity, text)

    def _health_bits(self):
        nav = self.nav
        h = SENSORS_PRESENT
        if not nav.imu.health.healthy():
            h &= ~(S_GYRO | S_ACCEL)
        if not nav.mag.health.healthy():
            h &= ~S_MAG
        if not nav.depth.health.healthy() or self._depth_implausible:
            h &= ~S_PRESSURE
        status = nav.est.status[0]
        if not status & nv.ATTITUDE_VALID:
            h &= ~S_AHRS
        if not status & 0x008:  # FIX_OK: fixes arriving
            h &= ~S_VISION
        if not self.battery.health.healthy() or (self.raw >> BATTERY) & 1:
            h &= ~S_BATTERY
        if self.raw & _ARM_BLOCKERS or status & _ATT_DEPTH != _ATT_DEPTH:
            h &= ~S_PREARM
        self.sensors_health = h
        t = self.telemetry
        if t is not None:
            t.sensors_present = SENSORS_PRESENT
            t.sensors_enabled = SENSORS_PRESENT
            t.sensors_health = h

    def commanded_reset(self):
        """The watchdog reset at boot was a reboot the ground asked for
        (``Resume`` found the mark): no lock-up to report."""
        self._lockup = False

    def on_arm(self):
        """Armed by the operator: a watchdog reset's report has been seen and
        a depth sensor caught lying has been looked at; forget both."""
        self._lockup = False
        self._depth_implausible = False

    # ------------------------------------------------------- arming checks
    def arming_check(self):
        """``None`` when the vehicle may arm, else a ``shared/modes.py`` reason."""
        if self.params.get_int(self._i_arming) == 0:
            return None
        now = self._clock.ticks_ms()
        raw = self._conditions(now) if _ticks_diff(now, self._t0) >= GRACE_MS else self.raw
        if (raw >> LEAK) & 1:
            return M.LEAK
        if raw & ((1 << IMU) | (1 << DEPTH) | (1 << COMPASS) | (1 << BATT_MONITOR)):
            return M.SENSOR_FAULT
        if (raw >> BATTERY) & 1:
            return M.LOW_BATTERY
        nav = self.nav
        # the IMU live now, not only the attitude held over its last silence
        # (valid for 250 ms after it, for a planned stall's sake): a dive
        # does not start on an IMU that has just gone quiet
        if not nav.valid(_ARM_ATTITUDE):
            return M.NO_ATTITUDE
        if not nav.valid(nv.DEPTH_VALID):
            self._say(msg.MAV_SEVERITY_WARNING, _PREARM_DEPTH)
            return M.CHECK_FAILED
        inn = nav.est.innovation
        thresh = self.params.get(self._i_ekf_thresh)
        if (inn[0] > thresh) + (inn[1] > thresh) + (inn[2] > thresh) >= 2:
            self._say(msg.MAV_SEVERITY_WARNING, _PREARM_EKF)
            return M.CHECK_FAILED
        return None

    def failsafe_held(self):
        """``None`` when FAILSAFE may be left (the failsafes that switched to
        it have cleared), else ``IN_FAILSAFE`` after a STATUSTEXT naming one."""
        held = self._holding & self.active
        self._holding = held
        if not held:
            return None
        i = 0
        while not (held >> i) & 1:
            i += 1
        self._say(msg.MAV_SEVERITY_WARNING, self._held_texts[i])
        return M.IN_FAILSAFE

    def mode_check(self, mode):
        """``None`` when ``mode`` may be entered now, else a reason."""
        if mode != M.ATTITUDE and mode != M.VELOCITY and mode != M.TARGET:
            return None
        if not self.has_controller:
            self._say(msg.MAV_SEVERITY_WARNING, _NO_CONTROLLER)
            return M.CHECK_FAILED
        nav = self.nav
        if not nav.valid(nv.ATTITUDE_VALID):
            return M.NO_ATTITUDE
        if mode != M.ATTITUDE and not nav.valid(nv.POSITION_VALID):
            return M.NO_POSITION
        t = self.telemetry
        if mode == M.TARGET and (t is None or not t.has_target):
            if self.modes is not None and not self.modes.armed:
                # arming in TARGET: the target must be on board before the
                # dive leaves the link behind
                self._say(msg.MAV_SEVERITY_WARNING, _PREARM_TARGET)
            return M.NO_TARGET
        return None
