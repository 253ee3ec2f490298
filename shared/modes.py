"""Flight modes and their transitions, arming and disarming.

Modes (their numbers are HEARTBEAT's ``custom_mode``):

========  ==  ================================================================
DISARMED   0  servos at the safe position; the only unarmed mode
PASSIVE    1  a fixed wing configuration (``PASSIVE_WING_DEG``)
ATTITUDE   2  attitude held by the controller
VELOCITY   3  horizontal velocity and descent speed held
TARGET     4  land at a point on the bottom
FAILSAFE   5  the configured safe configuration (``FS_WING_DEG``)
========  ==  ================================================================

Transitions (``TRANSITIONS[from]`` is a bit set of the modes one may
request from there):

- DISARMED: only by arming (``arm()``), which lands in PASSIVE; any other
  request is refused with ``NOT_ARMED``.
- PASSIVE, ATTITUDE, VELOCITY, TARGET: to each other freely.
- FAILSAFE: reachable from every mode, DISARMED included (a leak while on
  deck still folds the wings); left only for PASSIVE or by disarming,
  so the operator takes over from a known configuration.
- ``disarm()`` is allowed from every mode.
- ``restore(mode)``: the firmware puts back the mode a reset under water
  interrupted (``firmware/resume.py``), from DISARMED only, without the
  checks: it is no arming by the operator (``arms`` counts those).

Arming and mode checks come from the firmware through ``checks``, an
object with ``arming_check() -> reason or None`` and, optionally,
``mode_check(mode) -> reason or None`` (e.g. TARGET needs a position
fix). Reasons are the module's string constants, never built per call, and
``REASONS.index(reason)`` is the number sent in COMMAND_ACK's
``result_param2``. ``request`` returns one of a fixed set of tuples, so a
refused or accepted request allocates nothing.
"""

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

DISARMED = const(0)
PASSIVE = const(1)
ATTITUDE = const(2)
VELOCITY = const(3)
TARGET = const(4)
FAILSAFE = const(5)

NAMES = ("DISARMED", "PASSIVE", "ATTITUDE", "VELOCITY", "TARGET", "FAILSAFE")

# Reasons: fixed strings, numbered by their place in REASONS.
OK = "ok"
NOT_ARMED = "not armed: arm first"
ALREADY_ARMED = "already armed"
UNKNOWN_MODE = "unknown mode"
IN_FAILSAFE = "in FAILSAFE: switch to PASSIVE or disarm first"
INVALID_TRANSITION = "transition not allowed"
NO_POSITION = "no position estimate"
NO_TARGET = "no target set"
SENSOR_FAULT = "sensor fault"
LEAK = "leak detected"
LOW_BATTERY = "battery low"
NO_ATTITUDE = "no attitude estimate"
CHECK_FAILED = "pre-arm check failed"

REASONS = (OK, NOT_ARMED, ALREADY_ARMED, UNKNOWN_MODE, IN_FAILSAFE, INVALID_TRANSITION,
           NO_POSITION, NO_TARGET, SENSOR_FAULT, LEAK, LOW_BATTERY, NO_ATTITUDE, CHECK_FAILED)

_FLIGHT = (1 << PASSIVE) | (1 << ATTITUDE) | (1 << VELOCITY) | (1 << TARGET)
#: Modes requestable from each mode (bit m set: mode m allowed), by mode.
TRANSITIONS = (
    (1 << DISARMED) | (1 << FAILSAFE),              # DISARMED: the rest needs arm()
    _FLIGHT | (1 << DISARMED) | (1 << FAILSAFE),    # PASSIVE
    _FLIGHT | (1 << DISARMED) | (1 << FAILSAFE),    # ATTITUDE
    _FLIGHT | (1 << DISARMED) | (1 << FAILSAFE),    # VELOCITY
    _FLIGHT | (1 << DISARMED) | (1 << FAILSAFE),    # TARGET
    (1 << PASSIVE) | (1 << DISARMED) | (1 << FAILSAFE),  # FAILSAFE
)

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


def mode_number(name):
    """Mode number for a name (any case), -1 if unknown (host side)."""
    name = name.upper()
    return NAMES.index(name) if name in NAMES else -1


class Modes:
    """The current mode and the rules for changing it.

    Parameters
    ----------
    checks:
        Firmware object with ``arming_check()`` and optionally
        ``mode_check(mode)``, each returning a reason string or None.
        None means no checks (tests, bench).
    """

    def __init__(self, checks=None):
        self.mode = DISARMED
        self.checks = checks
        self._arming_check = getattr(checks, "arming_check", None) if checks is not None else None
        self._mode_check = getattr(checks, "mode_check", None) if checks is not None else None
        #: Counts mode changes, so the firmware can react to one per cycle.
        self.changes = 0
        #: Counts the operator's armings (``arm()`` accepted).
        self.arms = 0
        #: Reason of the last FAILSAFE entry (a constant), or OK.
        self.failsafe_cause = OK
        self.last_refusal = OK

    @property
    def armed(self):
        return self.mode != DISARMED

    def _set(self, mode):
        if mode != self.mode:
            self.mode = mode
            self.changes += 1
        return ACCEPTED

    def _refuse(self, reason):
        self.last_refusal = reason
        return refusal(reason)

    def request(self, mode):
        """Ask for ``mode``; ``(accepted, reason)``, a constant tuple."""
        if not 0 <= mode < len(NAMES):
            return self._refuse(UNKNOWN_MODE)
        if mode == self.mode:
            return ACCEPTED
        if mode == FAILSAFE:
            return self.failsafe(OK)
        if mode == DISARMED:
            return self.disarm()
        if not (TRANSITIONS[self.mode] >> mode) & 1:
            if self.mode == DISARMED:
                return self._refuse(NOT_ARMED)
            if self.mode == FAILSAFE:
                return self._refuse(IN_FAILSAFE)
            return self._refuse(INVALID_TRANSITION)
        if self._mode_check is not None:
            reason = self._mode_check(mode)
            if reason is not None:
                return self._refuse(reason)
        return self._set(mode)

    def arm(self, force=False):
        """DISARMED -> PASSIVE when the arming check passes (``force`` skips it)."""
        if self.mode != DISARMED:
            return self._refuse(ALREADY_ARMED)
        if self._arming_check is not None and not force:
            reason = self._arming_check()
            if reason is not None:
                return self._refuse(reason)
        self.arms += 1
        return self._set(PASSIVE)

    def restore(self, mode):
        """Back to ``mode`` after a reset (from DISARMED, no checks); False
        when not DISARMED (someone chose a mode since) or ``mode`` is unknown."""
        if self.mode != DISARMED or not 0 <= mode < len(NAMES):
            return False
        if mode == FAILSAFE:
            self.failsafe_cause = CHECK_FAILED
        self._set(mode)
        return True

    def disarm(self):
        """Always allowed: servos go to the safe position."""
        return self._set(DISARMED)

    def failsafe(self, cause):
        """Enter FAILSAFE from any mode; ``cause`` is a reason constant."""
        self.failsafe_cause = cause
        return self._set(FAILSAFE)

    # ----------------------------------------------------- MAVLink mapping
    def custom_mode(self):
        return self.mode

    def base_mode(self):
        """HEARTBEAT base_mode: custom mode always, armed, stabilised, guided."""
        m = self.mode
        flags = _FLAG_CUSTOM_MODE_ENABLED
        if m != DISARMED:
            flags |= _FLAG_SAFETY_ARMED
        if m == ATTITUDE or m == VELOCITY or m == TARGET:
            flags |= _FLAG_STABILIZE_ENABLED
        if m == TARGET:
            flags |= _FLAG_GUIDED_ENABLED
        return flags

    def system_status(self):
        """HEARTBEAT system_status (MAV_STATE)."""
        if self.mode == FAILSAFE:
            return _STATE_CRITICAL
        if self.mode == DISARMED:
            return _STATE_STANDBY
        return _STATE_ACTIVE
