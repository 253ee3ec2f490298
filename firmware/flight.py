"""The control task: failsafes, then the mode's wing commands, then the servos.

``Flight.step()`` runs every 20 ms (50 Hz, the servos' frame rate):

1. every fifth call (10 Hz) the failsafes are evaluated, so an action they
   take (FAILSAFE mode, disarm) shapes this very step's commands;
2. a change of ``Modes.state`` (the mode when armed, DISARMED when not)
   is acted on: the operator's arming (``Modes.arms``; a state restored
   after a reset is none) zeroes the depth at the surface
   (``Navigation.zero_at_surface``) and clears a watchdog reset's report;
   entering a controlled mode resets the controller and gives it its
   setpoint (TARGET: the target from the ground, with its depth when the
   ground gave one, which is the bottom's there; VELOCITY: the ground's
   velocity setpoint, or hold still horizontally at the present descent
   speed; ATTITUDE: level at the present heading);
3. the wing commands: disarmed ``SERVO_SAFE_DEG`` whatever the mode,
   PASSIVE ``PASSIVE_WING_DEG``, FAILSAFE ``FS_WING_DEG`` on all four wings;
   ATTITUDE, VELOCITY and TARGET from the controller
   (``roboray.shared.control.Controller``: ``step(t_us, mode, est, out)``),
   which writes the four angles (rad) in place. A controller that raises
   puts the vehicle in FAILSAFE mode (reported) instead of stopping the
   task, since a task that fails every slot starves the watchdog;
4. the commands go to the estimator (its magnetometer gate and descent
   model need them) and to the servos.

Without a controller in the firmware the vehicle flies PASSIVE and FAILSAFE
only; ``firmware/failsafe.py`` refuses the controlled modes with a reason.
"""

from roboray.shared import modes as M
from roboray.shared.estimator.estimator import JOB_HOUSEKEEPING
from roboray.shared.mavlink import messages as msg

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_DEG = 0.017453292519943295
_FAILSAFE_EVERY = const(5)   # control steps between failsafe evaluations (10 Hz)
_CONTROLLER_FAILED = "controller failed: FAILSAFE mode"


def _controlled(mode):
    return mode == M.ATTITUDE or mode == M.VELOCITY or mode == M.TARGET


class Flight:
    """Modes to wing commands.

    Parameters
    ----------
    modes, wings, nav, failsafes:
        ``Modes``, the ``Wings`` servos, ``Navigation`` and ``Failsafes``.
    ep:
        The MAVLink endpoint (target and velocity setpoints, texts).
    telemetry:
        ``Telemetry`` (the target).
    params:
        The parameter table.
    clock:
        The ``time`` module.
    controller:
        A ``Controller`` or None.
    """

    def __init__(self, modes, wings, nav, failsafes, ep, telemetry, params, clock, controller=None):
        self.modes = modes
        self.wings = wings
        self.nav = nav
        self.failsafes = failsafes
        self.ep = ep
        self.t = telemetry
        self.params = params
        self.controller = controller
        self._clock = clock
        self._n = 0
        self._parked = False
        self._changes = modes.changes
        self._arms = modes.arms
        self._mode = modes.state
        self._target_seen = -1
        self._velocity_seen = -1
        self._i_safe = params.index("SERVO_SAFE_DEG")
        self._i_passive = params.index("PASSIVE_WING_DEG")
        self._i_fs = params.index("FS_WING_DEG")
        self._version = -1
        self._safe = 0.0
        self._passive = 0.0
        self._fs = 0.0
        self.controller_errors = 0
        self.last_error = None

    def _load(self):
        p = self.params
        self._version = p.version
        self._safe = p.get(self._i_safe) * _DEG
        self._passive = p.get(self._i_passive) * _DEG
        self._fs = p.get(self._i_fs) * _DEG
        self.wings.safe = self._safe

    def step(self):
        """Scheduler task (every 20 ms)."""
        n = self._n + 1
        # The failsafes (10 Hz) wait one step when the estimator's
        # housekeeping (10 Hz too) ran in this slot's nav step: in step, the
        # two made the longest slots (bench board --cpu-mhz 125: slot max
        # without flash saves 9.81 -> 9.05 ms, 1 -> 0 overruns)
        if n >= _FAILSAFE_EVERY and (n > _FAILSAFE_EVERY or self.nav.est.job != JOB_HOUSEKEEPING):
            n = 0
            self.failsafes.update()
        self._n = n
        if self.params.version != self._version:
            self._load()
        modes = self.modes
        if modes.changes != self._changes:
            self._changes = modes.changes
            self._changed(self._mode, modes.state)
            self._mode = modes.state
        mode = modes.state
        c = self.wings.command
        if mode == M.DISARMED:
            c[0] = c[1] = c[2] = c[3] = self._safe
        elif mode == M.PASSIVE:
            c[0] = c[1] = c[2] = c[3] = self._passive
        elif mode == M.FAILSAFE:
            c[0] = c[1] = c[2] = c[3] = self._fs
        else:
            self._control(mode, c)
        self.nav.est.wings(c[0], c[1], c[2], c[3])
        if self.failsafes.parked:        # a low pack, disarmed: no pulses (firmware/failsafe.py)
            if not self._parked:
                self._parked = True
                self.wings.off()
            return
        self._parked = False
        self.wings.update()

    def _control(self, mode, c):
        ctrl = self.controller
        ep = self.ep
        if mode == M.TARGET and ep.target_count != self._target_seen:
            self._target_seen = ep.target_count
            self._set_target()
        elif mode == M.VELOCITY and ep.velocity_count != self._velocity_seen:
            self._velocity_seen = ep.velocity_count
            v = ep.velocity_ned
            ctrl.set_velocity(v[0], v[1], v[2])
        try:
            ctrl.step(self._clock.ticks_us(), mode, self.nav.est, c)
        except Exception as e:  # a failing controller must not stop the servos' task
            self.controller_errors += 1
            self.last_error = e
            self.modes.failsafe(M.CHECK_FAILED)
            c[0] = c[1] = c[2] = c[3] = self._fs
            ep.send_text(msg.MAV_SEVERITY_CRITICAL, _CONTROLLER_FAILED)

    def _set_target(self):
        g = self.t.target_ned
        if g[2] > 0.0:   # the target's depth, when the ground gave one: the bottom there
            self.controller.set_target(g[0], g[1], g[2])
        else:
            self.controller.set_target(g[0], g[1])

    def _changed(self, old, new):
        if self.modes.arms != self._arms:
            # the operator armed (a state restored after a reset is no arming)
            self._arms = self.modes.arms
            self.nav.zero_at_surface()
            self.failsafes.on_arm()
        ctrl = self.controller
        if ctrl is None or not _controlled(new):
            return
        if not _controlled(old):
            ctrl.reset()
        est = self.nav.est
        if new == M.TARGET:
            self._target_seen = self.ep.target_count
            self._set_target()
        elif new == M.VELOCITY:
            ep = self.ep
            self._velocity_seen = ep.velocity_count
            if ep.velocity_count:
                v = ep.velocity_ned
                ctrl.set_velocity(v[0], v[1], v[2])
            else:
                ctrl.set_velocity(0.0, 0.0, est.nav[1])
        else:
            ctrl.set_attitude(0.0, 0.0, est.euler[2])
