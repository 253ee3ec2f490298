"""Flight modes, arming, and their MAVLink numbers.

Arming is a flag, as on every ArduPilot vehicle: the mode is kept across
arming and disarming, and a disarmed vehicle holds its servos at the safe
position (``SERVO_SAFE_DEG``) whatever its mode. The board starts
disarmed in PASSIVE.

Modes (internal number; HEARTBEAT ``custom_mode``, ArduSub's number for the
mode that does the same, so MAVProxy, pymavlink and QGroundControl, which
name a MAV_TYPE_SUBMARINE's modes from ArduSub's table, show a name that
says what it does and switch to each mode by that name; docs/design/
handshake.md has the reasons):

========  ==  ======  =========  =============================================
mode      #   custom  ArduSub    what the wings do
========  ==  ======  =========  =============================================
PASSIVE   1   19      MANUAL     a fixed configuration (``PASSIVE_WING_DEG``)
ATTITUDE  2   0       STABILIZE  attitude held by the controller
VELOCITY  3   4       GUIDED     the ground's velocity setpoint held
TARGET    4   3       AUTO       land at the target (the mission's one item)
FAILSAFE  5   9       SURFACE    the safe configuration (``FS_WING_DEG``)
========  ==  ======  =========  =============================================

``Modes.state`` is what the vehicle does: its mode when armed, ``DISARMED``
(0, no mode) when not; the controller (``step(t, state, ...)``), the twin's
records and the board time model index by it, and ``NAMES[state]`` names it.

Rules (ArduPilot's):

- any mode may be selected while disarmed; the checks come at arming
  (``arming_check()``, then ``mode_check(mode)`` for the mode it arms in),
  as ArduCopter defers a disarmed vehicle's mode checks to its arming;
- armed, a mode is entered when ``mode_check(mode)`` passes (TARGET needs a
  position estimate and a target);
- a failsafe is an event: it switches to FAILSAFE once, when its condition
  appears (``failsafe(cause)``), and FAILSAFE is then a mode like the
  others. The operator may select another as soon as the cause is gone:
  while the failsafe that switched it is still active, ``checks.
  failsafe_held()`` refuses (``IN_FAILSAFE``). FAILSAFE the operator chose
  is left freely;
- ``disarm()`` is always allowed and keeps the mode;
- ``restore(mode, armed)``: the firmware puts back the state a reset under
  water interrupted (``firmware/resume.py``), while nobody has changed it
  since the boot, without the checks: it is no arming by the operator
  (``arms`` counts those).

Checks come from the firmware through ``checks``, an object with
``arming_check() -> reason or None`` and, optionally, ``mode_check(mode)``
and ``failsafe_held()``, each returning a reason or None. Reasons are the
module's string constants, never built per call, and
``REASONS.index(reason)`` is the number sent in COMMAND_ACK's
``result_param2``. ``request`` returns one of a fixed set of tuples, so a
refused or accepted request allocates nothing.
"""

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

DISARMED = const(0)   # no mode: Modes.state of a disarmed vehicle
PASSIVE = const(1)
ATTITUDE = const(2)
VELOCITY = const(3)
TARGET = const(4)
FAILSAFE = const(5)
COUNT = const(6)      # state numbers: DISARMED and the five modes

#: Names by state number (``NAMES[DISARMED]`` names the disarmed state).
NAMES = ("DISARMED", "PASSIVE", "ATTITUDE", "VELOCITY", "TARGET", "FAILSAFE")
#: The modes, in the order AVAILABLE_MODES lists them (its index - 1).
MODES = (PASSIVE, ATTITUDE, VELOCITY, TARGET, FAILSAFE)
#: HEARTBEAT ``custom_mode`` by mode number (ArduSub's: MANUAL, STABILIZE,
#: GUIDED, AUTO, SURFACE); index 0 unused.
CUSTOM = (-1, 19, 0, 4, 3, 9)
#: The name MAVProxy, pymavlink and QGroundControl show for each mode
#: (pymavlink's ``mode_mapping_sub``); ``roboray-ground mode`` takes them too.
ARDUSUB_NAMES = ("", "MANUAL", "STABILIZE", "GUIDED", "AUTO", "SURFACE")
#: MAV_STANDARD_MODE by mode number: TARGET flies the mission's one item
#: (MISSION, 6); the others match none (NON_STANDARD, 0).
STANDARD = (0, 0, 0, 0, 6, 0)
BOOT_MODE = PASSIVE

# Reasons: fixed strings, numbered by their place in REASONS.
OK = "ok"
UNKNOWN_MODE = "unknown mode"
IN_FAILSAFE = "in FAILSAFE until its cause clears (or disarm)"
NO_POSITION = "no position estimate"
NO_TARGET = "no target set"
SENSOR_FAULT = "sensor fault"
LEAK = "leak detected"
LOW_BATTERY = "battery low"
NO_ATTITUDE = "no attitude estimate"
CHECK_FAILED = "pre-arm check failed"

REASONS = (OK, UNKNOWN_MODE, IN_FAILSAFE, NO_POSITION, NO_TARGET, SENSOR_FAULT, LEAK, LOW_BATTERY,
           NO_ATTITUDE, CHECK_FAILED)

# HEARTBEAT base_mode flags (MAV_MODE_FLAG)
_FLAG_CUSTOM_MODE_ENABLED = const(1)
_FLAG_GUIDED_ENABLED = const(8)
_FLAG_STABILIZE_ENABLED = const(16)
_FLAG_SAFETY_ARMED = const(128)
# HEARTBEAT system_status (MAV_STATE)
_STATE_STANDBY = const(3)
_STATE_ACTIVE = const(4)
_STATE_CRITICAL = const(5)

ACCEPTED = (True, OK)
_REFUSALS = {}
for _r in REASONS:
    _REFUSALS[_r] = (False, _r)


def refusal(reason):
    """The constant ``(False, reason)`` tuple for a reason."""
    r = _REFUSALS.get(reason)
    return r if r is not None else (False, reason)


def from_custom(custom):
    """The mode of a HEARTBEAT ``custom_mode``, -1 if none."""
    for m in MODES:
        if CUSTOM[m] == custom:
            return m
    return -1


def from_standard(standard):
    """The mode of a MAV_STANDARD_MODE, -1 if none (NON_STANDARD is none)."""
    if standard == 0:
        return -1
    for m in MODES:
        if STANDARD[m] == standard:
            return m
    return -1


def mode_number(name):
    """The mode of a name (any case), RoboRay's or the ArduSub name ground
    stations show; -1 if none (DISARMED is no mode). Host side."""
    name = name.upper()
    for m in MODES:
        if NAMES[m] == name or ARDUSUB_NAMES[m] == name:
            return m
    return -1


def custom_name(custom):
    """RoboRay's name of a HEARTBEAT ``custom_mode`` (``MODE n`` if none). Host side."""
    m = from_custom(custom)
    return NAMES[m] if m >= 0 else "MODE %d" % custom


class Modes:
    """The mode, the armed flag and the rules for changing them.

    Parameters
    ----------
    checks:
        Firmware object with ``arming_check()`` and optionally
        ``mode_check(mode)`` and ``failsafe_held()``, each returning a
        reason string or None. None means no checks (tests, bench).

    Attributes: ``mode`` (a mode number), ``armed``, ``state`` (``mode``
    when armed, else DISARMED), ``intended`` (the mode the operator last
    chose: CURRENT_MODE's ``intended_custom_mode``), ``changes`` (counts
    changes of the mode or the arming, so the firmware can react to one
    per cycle),
    ``arms`` (the operator's armings), ``failsafe_cause`` (why FAILSAFE was
    last entered, a reason constant), ``last_refusal``.
    """

    def __init__(self, checks=None):
        self.mode = BOOT_MODE
        self.armed = False
        self.state = DISARMED
        self.intended = BOOT_MODE
        self.checks = checks
        self._arming_check = getattr(checks, "arming_check", None) if checks is not None else None
        self._mode_check = getattr(checks, "mode_check", None) if checks is not None else None
        self._held = getattr(checks, "failsafe_held", None) if checks is not None else None
        self.changes = 0
        self.arms = 0
        self.failsafe_cause = OK
        self.last_refusal = OK

    def _set(self, mode, armed):
        if mode != self.mode or armed != self.armed:
            self.mode = mode
            self.armed = armed
            self.state = mode if armed else DISARMED
            self.changes += 1
        return ACCEPTED

    def _refuse(self, reason):
        self.last_refusal = reason
        return refusal(reason)

    def request(self, mode):
        """The operator asks for ``mode``; ``(accepted, reason)``, a constant tuple."""
        if not PASSIVE <= mode <= FAILSAFE:
            return self._refuse(UNKNOWN_MODE)
        if mode == self.mode:
            self.intended = mode
            return ACCEPTED
        if self.armed:
            if self.mode == FAILSAFE and self._held is not None:
                reason = self._held()
                if reason is not None:
                    return self._refuse(reason)
            if self._mode_check is not None:
                reason = self._mode_check(mode)
                if reason is not None:
                    return self._refuse(reason)
        if mode == FAILSAFE:
            self.failsafe_cause = OK
        self.intended = mode
        return self._set(mode, self.armed)

    def arm(self, force=False):
        """Arm in the present mode when the arming check and the mode's
        check pass (``force`` skips both); arming an armed vehicle is accepted."""
        if self.armed:
            return ACCEPTED
        if not force:
            if self._arming_check is not None:
                reason = self._arming_check()
                if reason is not None:
                    return self._refuse(reason)
            if self._mode_check is not None:
                reason = self._mode_check(self.mode)
                if reason is not None:
                    return self._refuse(reason)
        self.arms += 1
        return self._set(self.mode, True)

    def disarm(self):
        """Always allowed: the servos go to the safe position, the mode stays."""
        return self._set(self.mode, False)

    def failsafe(self, cause):
        """A failsafe switches to FAILSAFE; ``cause`` is a reason constant."""
        self.failsafe_cause = cause
        return self._set(FAILSAFE, self.armed)

    def restore(self, mode, armed):
        """Back to ``mode`` (armed or not) after a reset, without the checks;
        False when the vehicle was armed since the boot or ``mode`` is unknown."""
        if self.armed or not PASSIVE <= mode <= FAILSAFE:
            return False
        if mode == FAILSAFE:
            self.failsafe_cause = CHECK_FAILED
        else:
            self.intended = mode
        self._set(mode, armed)
        return True

    # ----------------------------------------------------- MAVLink mapping
    def custom_mode(self):
        return CUSTOM[self.mode]

    def base_mode(self):
        """HEARTBEAT base_mode: custom mode always; armed; stabilised in the
        controlled modes, guided where the ground gives the goal (ArduSub's
        GUIDED and AUTO)."""
        m = self.mode
        flags = _FLAG_CUSTOM_MODE_ENABLED
        if self.armed:
            flags |= _FLAG_SAFETY_ARMED
        if m == ATTITUDE or m == VELOCITY or m == TARGET:
            flags |= _FLAG_STABILIZE_ENABLED
            if m != ATTITUDE:
                flags |= _FLAG_GUIDED_ENABLED
        return flags

    def system_status(self):
        """HEARTBEAT system_status (MAV_STATE): standby disarmed, critical in FAILSAFE."""
        if not self.armed:
            return _STATE_STANDBY
        if self.mode == FAILSAFE:
            return _STATE_CRITICAL
        return _STATE_ACTIVE
