"""A dive survives a reset: the state is kept, and restored under water.

A reset under water (the watchdog's, after a lock-up, or a power cut) used
to end the mission: the board came back disarmed, and no one can reach a
vehicle at 8 m to arm it again. ArduPilot re-arms after a watchdog reset in
flight; so does this firmware, after a power cut as well, when the vehicle
is under water.

Keeping. ``Resume.update()`` runs after the control step (50 Hz) and
compares three counters: changes of mode or arming, the operator's
armings and targets received. When one moved (an event, never a step's
worth of change) it packs the dive's state (``dive_state.DiveState``: mode
and armed, target, surface pressure, gyro bias) into the watchdog's scratch
words at once (``drivers/scratch.py``, 16 bytes; they survive a watchdog
reset) and saves it on flash
(``flash_record.FlashRecord`` beside the parameters; it survives a power
cut), telling the scheduler of the flash stall first (``expect_delay``).

Restoring. At boot the state comes from the scratch words after a
watchdog reset (they are newer than flash if the reset came in the middle
of a save), else from flash. The surface pressure goes back into the
estimator at once. When the state says armed, the decision waits for the
first pressure (the loop's first 40 ms or so):

- at least ``RESUME_DEPTH_M`` under the stored surface: the vehicle is in
  the water. The target goes back to the telemetry, the gyro bias and a
  short alignment to the estimator (``Estimator.resume``), and the mode,
  armed, to ``Modes.restore`` (no arming checks: it is no new arming, so
  the depth is not zeroed again; the failsafes act on what is active then,
  ``firmware/failsafe.py``);
- shallower: it may be a vehicle that is just sinking after a reset at the
  surface, so the decision waits, up to ``SURFACE_WAIT_MS``, for the depth
  to pass ``RESUME_DEPTH_M``; a board that stays shallower (on the bench,
  on deck, switched off armed) stays disarmed in the boot's mode, and the
  state is saved disarmed so it does not come back;
- no pressure within ``DEPTH_WAIT_MS``: disarmed (nothing says where it is).

Any mode or arming the operator or a failsafe chooses meanwhile wins: the
decision is dropped when the mode or the arming changed since the boot.

Reporting. The decision goes to the ground as a STATUSTEXT naming the
reset's cause and the depth ("Watchdog reset at 3.2 m: resumed TARGET",
"Power lost at 0.0 m (surface): disarmed"), CRITICAL when it resumed,
WARNING when it did not, sent again every ``TEXT_RETRY_MS`` until a
ground heartbeat arrives after it, and printed on the console.
"""

from roboray.firmware import dive_state as ds
from roboray.firmware import navigation as nv
from roboray.shared import modes as M
from roboray.shared.mavlink import messages as msg

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

#: Depth (m) under the stored surface pressure that says "under water".
#: Well above the weather's drift of the surface pressure over a day (a few
#: cm) and the vehicle held at the surface (5 cm).
RESUME_DEPTH_M = 0.5
#: How long a shallower vehicle may take to sink past it, ms.
SURFACE_WAIT_MS = const(10000)
#: How long the first pressure may take, ms.
DEPTH_WAIT_MS = const(3000)
#: The report is repeated this often until the ground's heartbeat is seen, ms.
TEXT_RETRY_MS = const(2000)
#: The estimator's fast alignment after a resume, s (8 s from a cold start).
ALIGN_S = 1.0
#: How long the restored mode waits for the estimate it needs, ms; then it
#: is restored anyway, and the estimator failsafe judges.
ESTIMATE_WAIT_MS = const(5000)

_WAIT_DEPTH = const(1)
_WAIT_ESTIMATE = const(2)
_ATT_DEPTH = nv.ATTITUDE_VALID | nv.DEPTH_VALID
_ALL_VALID = nv.ATTITUDE_VALID | nv.DEPTH_VALID | nv.POSITION_VALID

_G = 9.80665
#: appended to the resume's text when the reset lost parameters set in flight
_LOST = "; parameters set in flight lost"


def _ticks_diff(a, b):
    return ((a - b + 0x20000000) & 0x3FFFFFFF) - 0x20000000


class Resume:
    """The dive's state kept across resets (see the module docstring).

    Parameters
    ----------
    nav, modes, telemetry, ep, params:
        ``Navigation``, ``Modes``, ``Telemetry``, the MAVLink endpoint and
        the parameter table.
    scratch:
        ``drivers.scratch.Scratch`` (the watchdog's words), or None.
    record:
        ``flash_record.FlashRecord``, or None.
    cause:
        What the reset was: ``"watchdog"`` (``machine.WDT_RESET``),
        ``"power"`` (a power-on) or another word.
    clock:
        The ``time`` module.
    """

    def __init__(self, nav, modes, telemetry, ep, params, scratch, record, cause, clock):
        self.nav = nav
        self.modes = modes
        self.t = telemetry
        self.ep = ep
        self.params = params
        self.scratch = scratch
        self.record = record
        self.cause = cause
        self._clock = clock
        self._buf = bytearray(ds.SIZE)
        self._i_gnd = params.index("BARO1_GND_PRESS")
        self._rho_g = 1000.0 * params.get(params.index("BARO_SPEC_GRAV")) * _G
        #: The state as last kept (and, after boot, as loaded).
        self.state = ds.DiveState()
        #: Where the state came from at boot: "scratch", "flash" or None.
        self.source = None
        #: The mode restored (-1: none), the depth the decision saw (m).
        self.resumed = -1
        self.depth_m = 0.0
        self.pending = False
        self._wait = 0
        self._t_wait = 0
        self.saves = 0
        self.save_errors = 0
        self.last_error = None
        self.text = None
        self.texts_sent = 0
        self._severity = msg.MAV_SEVERITY_WARNING
        self._text_ms = 0
        self._gcs_at_text = -1
        self._t0 = clock.ticks_ms()
        #: parameters set before the reset were still waiting for their
        #: save (``ParamStore.held``): the reset lost them
        self.params_lost = False
        self._load()
        self._changes = modes.changes
        self._arms = modes.arms
        self._targets = ep.target_count

    # ------------------------------------------------------------ boot
    def _load(self):
        s = self.state
        buf = self._buf
        if self.cause == "watchdog" and self.scratch is not None and s.unpack(self.scratch.read_into(buf)):
            self.source = "scratch"
            if s.reboot:
                # the ground's reboot, not a lock-up; the words lose the mark
                # so a lock-up later in this run is reported as one
                self.cause = "reboot"
                s.reboot = False
                self.scratch.write(s.pack(buf))
        elif self.record is not None:
            try:
                data = self.record.load()
            except OSError as e:
                data = None
                self.last_error = str(e)
            if s.unpack(data):
                self.source = "flash"
        if self.source is None:
            return
        self.params_lost = s.params_unsaved
        s.params_unsaved = False
        # the depth is measured from the surface of this dive
        p0 = s.surface_pa
        i = self._i_gnd
        if abs(self.params.get(i) - p0) > 2.0:
            self.params.set(i, p0)
        self.nav.est.zero_depth(p0, 0.0)
        if s.armed:
            self.pending = True
            self._wait = _WAIT_DEPTH

    def describe(self):
        """One line for the start-up log."""
        if self.source is None:
            return "dive state: none kept"
        s = self.state
        return "dive state from %s: %s%s%s%s%s" % (
            self.source, M.NAMES[s.mode], "" if s.armed else ", disarmed",
            ", waiting for the depth to resume" if self.pending else "",
            " (rebooted on command)" if self.cause == "reboot" else "",
            _LOST if self.params_lost else "")

    def params_held(self, held):
        """The parameter store's save waits (``held``) or was made: the
        scratch words say so (no flash write in flight), so a watchdog
        reset before the save is reported as losing those changes; the
        flash record carries it from its next event."""
        self.state.params_unsaved = held
        if self.scratch is not None:
            self.scratch.write(self._save_fields())

    def mark_reboot(self):
        """Just before a reboot the ground asked for: the scratch words say
        so, and the next boot does not take the reset for a lock-up (the rp2
        port's ``machine.reset()`` goes through the watchdog). Only the
        scratch words: a power cut is no reboot."""
        if self.scratch is None:
            return
        s = self.state
        s.reboot = True
        self.scratch.write(self._save_fields())
        s.reboot = False

    def _decide(self, now):
        nav = self.nav
        waited = _ticks_diff(now, self._t0)
        if self.modes.changes != self._changes:
            self.pending = False    # the operator or a failsafe chose: theirs wins
            return
        if self._wait == _WAIT_ESTIMATE:
            mode = self.state.mode
            need = _ALL_VALID if mode == M.VELOCITY or mode == M.TARGET else _ATT_DEPTH
            if nav.valid(need) or _ticks_diff(now, self._t_wait) >= ESTIMATE_WAIT_MS:
                self._restore()
            return
        if not nav.depth_samples:
            if waited >= DEPTH_WAIT_MS:
                self._give_up("%s, no depth reading: disarmed")
            return
        d = (nav.depth.pressure_pa - self.state.surface_pa) / self._rho_g
        self.depth_m = d
        if d >= RESUME_DEPTH_M:
            self._prepare(now)
        elif waited >= SURFACE_WAIT_MS:
            self._give_up("%s at %.1f m (surface): disarmed")

    def _cause_text(self):
        c = self.cause
        if c == "watchdog":
            return "Watchdog reset"
        return "Power lost" if c == "power" else ("Reboot" if c == "reboot" else "Reset")

    def _give_up(self, fmt):
        self.pending = False
        if "%.1f" in fmt:
            text = fmt % (self._cause_text(), self.depth_m)
        else:
            text = fmt % self._cause_text()
        if self.params_lost:
            text += _LOST
        self._say(msg.MAV_SEVERITY_WARNING, text)
        self._save()    # disarmed: a later boot does not bring the old dive back

    def _prepare(self, now):
        """Under water: the target and the estimator's warm start; the mode
        waits for the estimate it needs (an armed mode without it would
        trip the estimator failsafe while the estimator aligns)."""
        s = self.state
        t = self.t
        if s.has_target:
            g = t.target_ned
            g[0] = s.north
            g[1] = s.east
            g[2] = s.down
            t.has_target = True
        b = s.bias
        self.nav.est.resume(b[0], b[1], b[2], ALIGN_S)
        self._wait = _WAIT_ESTIMATE
        self._t_wait = now

    def _restore(self):
        s = self.state
        self.pending = False
        if not self.modes.restore(s.mode, True):
            return
        self.resumed = s.mode
        self._changes = self.modes.changes
        self._say(msg.MAV_SEVERITY_CRITICAL, "%s at %.1f m: resumed %s%s"
                  % (self._cause_text(), self.depth_m, M.NAMES[s.mode], _LOST if self.params_lost else ""))

    def _say(self, severity, text):
        print("resume: " + text)
        self.text = text
        self._severity = severity
        self._send(self._clock.ticks_ms())

    def _send(self, now):
        ep = self.ep
        ep.send_text(self._severity, self.text)
        self.texts_sent += 1
        self._text_ms = now
        self._gcs_at_text = ep.gcs_last_ms

    # ------------------------------------------------------------ the task
    def update(self):
        """After each control step: the boot's decision, the report, and the
        state kept when an event changed it."""
        if self.pending:
            self._decide(self._clock.ticks_ms())
            return
        if self.text is not None:
            gcs = self.ep.gcs_last_ms
            if gcs >= 0 and gcs != self._gcs_at_text:
                self.text = None    # the ground is there, and heard since
            else:
                now = self._clock.ticks_ms()
                if _ticks_diff(now, self._text_ms) >= TEXT_RETRY_MS:
                    self._send(now)
        m = self.modes
        ep = self.ep
        if m.changes != self._changes or m.arms != self._arms or ep.target_count != self._targets:
            self._changes = m.changes
            self._arms = m.arms
            self._targets = ep.target_count
            self._save()

    def _save(self):
        """The state now into the scratch words and on flash."""
        buf = self._save_fields()
        if self.scratch is not None:
            self.scratch.write(buf)
        if self.record is not None:
            try:
                self.record.save(bytes(buf))
            except OSError as e:
                self.save_errors += 1
                self.last_error = str(e)
                return
        self.saves += 1

    def _save_fields(self):
        """The state now into ``state`` and packed into the buffer."""
        s = self.state
        s.mode = self.modes.mode
        s.armed = self.modes.armed
        t = self.t
        s.has_target = t.has_target
        g = t.target_ned
        s.north = g[0]
        s.east = g[1]
        s.down = g[2]
        s.surface_pa = self.params.get(self._i_gnd)
        b = self.nav.est.att.bias
        sb = s.bias
        sb[0] = b[0]
        sb[1] = b[1]
        sb[2] = b[2]
        return s.pack(self._buf)
