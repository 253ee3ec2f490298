"""The ground link: the MAVLink endpoint on the radio, as one scheduler task.

``Link.step()`` (every 10 ms) pushes what the radio queued
(``Radio.service``) and lets the endpoint (``shared/mavlink/endpoint.py``)
handle what arrived and send what is due, one frame's work a slot (the
endpoint's budget: a received frame parsed, or handled, or one frame
built). The telemetry (``firmware/telemetry.py``) is filled a stream at a
time, just before the endpoint sends that stream (``Reporter.refresh``).
Running every slot, it sees every slot's time (the scheduler's
``last_loop_us``, the slot before this one) and keeps the longest in the
endpoint's ``slot_max_us``, which the status report sends and starts over.
What the ground sends reaches the rest of the firmware through it:

- position fixes (ATT_POS_MOCAP) go to ``Navigation.fix`` as they arrive;
- a target (DO_REPOSITION, SET_POSITION_TARGET_LOCAL_NED with position bits)
  lands in ``Telemetry.target_ned`` (the endpoint's doing);
- a velocity setpoint (SET_POSITION_TARGET_LOCAL_NED in MAV_FRAME_LOCAL_NED
  with the velocity bits of ``type_mask`` clear) lands in
  ``velocity_ned``, counted in ``velocity_count``; the endpoint itself
  handles only position setpoints, so ``VehicleEndpoint`` adds this;
- a landing in TARGET (``firmware/landing.py``) is the mission's target
  reached: MISSION_ITEM_REACHED (``shared/mavlink/mission.py``);
- arm, disarm and mode commands go to ``shared/modes.py`` (the endpoint's
  doing, through the arming and mode checks of ``firmware/failsafe.py``);
- a reboot (PREFLIGHT_REBOOT_SHUTDOWN, refused while armed) saves the
  parameters if they changed, marks the reset as asked for (``on_reboot``:
  the rp2 port's ``machine.reset()`` reads as a watchdog reset at the next
  boot), lets the COMMAND_ACK leave the UART (``Radio.drained``: a reset
  drops what the UART still holds, and the ACK was lost) and resets the
  board (``machine.reset()``).

Signing (docs/design/signing.md): the key and the signing clock live in one
``FlashRecord`` (``firmware/flash_record.py``) beside the parameter file,
``signing.bin``: the 32-byte key (zeros: none), then the clock's 24-bit
halves (two u32). ``SigningKeeper`` loads it when the link is built (at
boot, before the first frame), with the clock set ``BOOT_MARGIN_S`` past the
saved value, and saves it when SETUP_SIGNING changed it, at disarm when the
clock advanced, and while the clock runs at most every ``SAVE_EVERY_S``
(ArduPilot's rule); a clock more than ``SAVE_JUMP_S`` past the saved value
(a step from the ground's time) is saved at the next slot. So every
timestamp accepted before a reset is below the saved value plus
``SAVE_JUMP_S``, and the boot margin puts the new-stream floor (our clock
less a minute) above them all: a frame recorded before a reset is refused
after it.
"""

import struct
from array import array

from roboray.firmware.flash_record import FlashRecord
from roboray.firmware.landing import Touchdown
from roboray.shared.mavlink import messages as msg
from roboray.shared.mavlink.endpoint import Endpoint, ticks_diff
from roboray.shared.mavlink.position_input import velocity_ok
from roboray.shared.mavlink.signing import Signing

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_VELOCITY_BITS = const(0x38)
_FLUSH_TRIES = const(40)    # x 5 ms: time the COMMAND_ACK of a reboot gets to leave

#: The signing record's name, beside the parameter file.
SIGNING_FILE = "signing.bin"
#: At boot the clock starts this far past the saved value (s): the unsaved
#: advance (< SAVE_JUMP_S) plus the new-stream minute.
BOOT_MARGIN_S = 120
#: The clock is saved at most this often while it runs (s)...
SAVE_EVERY_S = 30
#: ...and at once when it is this far past the saved value (s).
SAVE_JUMP_S = 60
_UNITS_S = const(100000)    # signing timestamp units a second


class SigningKeeper:
    """The signing key and clock on flash (``record``, a ``FlashRecord``).

    ``load()`` at boot; ``service(now_ms, armed)`` every link slot (cheap
    unless a save is due); ``save()`` after SETUP_SIGNING. ``store`` is the
    ``ParamStore``: its ``expect_delay`` (the scheduler's) is told before a
    save stalls the chip. ``saves`` and ``save_errors`` count.
    """

    def __init__(self, signing, record, store=None):
        self.signing = signing
        self.record = record
        self.store = store
        self.saved_hi = 0
        self.saved_lo = 0
        self.saved_ms = -1
        self.saves = 0
        self.save_errors = 0
        self.loaded = False
        self._armed = False

    def load(self):
        """Key and clock from flash; True when a key is now set."""
        data = self.record.load()
        s = self.signing
        if data is None or len(data) != 40:
            return False
        hi, lo = struct.unpack_from("<II", data, 32)
        key = data[:32]
        s.set_key(None if key == bytes(32) else key)
        s.advance(hi, lo)
        self.saved_hi = s.hi
        self.saved_lo = s.lo
        # past anything accepted before the reset (see the module docstring)
        s.advance(hi + (lo + BOOT_MARGIN_S * _UNITS_S) // 0x1000000, (lo + BOOT_MARGIN_S * _UNITS_S) & 0xFFFFFF)
        self.loaded = True
        return s.key is not None

    def save(self):
        """Write key and clock now; False (counted) when flash failed."""
        s = self.signing
        store = self.store
        if store is not None and store.expect_delay is not None:
            self.record.expect_delay = store.expect_delay
        hi = s.hi
        lo = s.lo
        data = bytearray(40)
        if s.key is not None:
            data[0:32] = s.key
        struct.pack_into("<II", data, 32, hi, lo)
        try:
            self.record.save(bytes(data))
        except OSError:
            self.save_errors += 1
            return False
        self.saved_hi = hi
        self.saved_lo = lo
        self.saves += 1
        return True

    def _past(self, seconds):
        """Whether the clock is more than ``seconds`` past the saved value."""
        s = self.signing
        lo = self.saved_lo + seconds * _UNITS_S
        hi = self.saved_hi
        if lo > 0xFFFFFF:
            lo -= 0x1000000
            hi += 1
        return s.hi > hi or (s.hi == hi and s.lo > lo)

    def service(self, now_ms, armed):
        """Save when due: at disarm, every SAVE_EVERY_S, after a jump."""
        was = self._armed
        self._armed = armed
        if self.signing.key is None:
            return False
        if self.saved_ms < 0:
            self.saved_ms = now_ms
        due = False
        if was and not armed:
            due = self._past(0)
        elif self._past(SAVE_JUMP_S):
            due = True
        elif self._past(SAVE_EVERY_S) and ticks_diff(now_ms, self.saved_ms) >= SAVE_EVERY_S * 1000:
            due = True
        if not due:
            return False
        self.saved_ms = now_ms
        return self.save()


class VehicleEndpoint(Endpoint):
    """The shared endpoint plus velocity setpoints (``velocity_ned``, m/s, NED)."""

    def __init__(self, *args, **kwargs):
        Endpoint.__init__(self, *args, **kwargs)
        self.velocity_ned = array("f", [0.0, 0.0, 0.0])
        self.velocity_count = 0

    def _handle(self, p):
        rejected = self.rejected
        Endpoint._handle(self, p)   # signing, and position setpoints
        if p.msgid != msg.MSG_SET_POSITION_TARGET_LOCAL_NED or self.rejected != rejected:
            return
        pl = p.payload
        if (pl[48] & _VELOCITY_BITS) == 0 and pl[52] == msg.MAV_FRAME_LOCAL_NED and self._for_us(pl[50], pl[51]):
            vx, vy, vz = struct.unpack_from("<3f", pl, 16)
            if velocity_ok(self, vx, vy, vz):   # finite and flyable
                v = self.velocity_ned
                v[0] = vx
                v[1] = vy
                v[2] = vz
                self.velocity_count += 1


class Link:
    """The endpoint over ``radio`` and what it feeds.

    Parameters
    ----------
    radio:
        The ``Radio`` driver (transport with ``read_into``/``write``).
    params, modes, telemetry:
        The parameter table, ``Modes`` and ``Telemetry``.
    nav:
        ``Navigation`` (fixes go to it).
    reporter:
        ``firmware.telemetry.Reporter``.
    store:
        The ``ParamStore`` (a reboot saves pending changes first).
    machine, clock:
        The ``machine`` and ``time`` modules.
    """

    def __init__(self, radio, params, modes, telemetry, nav, reporter, store, machine, clock):
        self.radio = radio
        self.nav = nav
        self.reporter = reporter
        self.store = store
        self._machine = machine
        self._clock = clock
        self.modes = modes
        #: called just before a commanded reboot resets the board (the
        #: application marks the reset as asked for: ``Resume.mark_reboot``)
        self.on_reboot = None
        self.signing = Signing()
        path = store.path
        self.keeper = SigningKeeper(self.signing, FlashRecord(path[:path.rfind("/") + 1] + SIGNING_FILE, store.fs),
                                    store)
        try:
            self.keeper.load()
        except OSError:
            pass    # no usable record: no key
        self.ep = VehicleEndpoint(radio, params, modes, telemetry, self.signing, on_fix=self._on_fix,
                                  on_refresh=reporter.refresh)
        self.ep.on_setup_signing = self.keeper.save
        self.touchdown = Touchdown(nav, modes)
        self.telemetry = telemetry
        self.params = params
        try:    # AUTOPILOT_VERSION says which build this is
            from roboray.firmware import build_info
            self.ep.set_version(build_info.VERSION, build_info.REVISION)
        except (ImportError, AttributeError):
            pass    # no build wrote it (CPython, the test interpreter): unknown

    def _on_fix(self, fix):
        self.nav.fix(fix[0], fix[1])

    def step(self):
        """Scheduler task (every 10 ms)."""
        self.radio.service()
        ep = self.ep
        sched = self.reporter.sched
        if sched is not None:
            # the previous slot's time: the status report sends the longest
            w = sched.last_loop_us
            if w > ep.slot_max_us:
                ep.slot_max_us = w
        now = self._clock.ticks_ms()
        ep.update(now)
        if self.touchdown.update(now):
            ep.mission.reached()
        self.keeper.service(now, self.modes.armed)
        if ep.reboot_requested:
            ep.reboot_requested = False
            self.reboot()

    def send_text(self, severity, text):
        self.ep.send_text(severity, text)

    def reboot(self):
        """Save changed parameters, let the radio drain, reset the board."""
        self.ep.send_text(msg.MAV_SEVERITY_INFO, "rebooting")
        if self.on_reboot is not None:
            self.on_reboot()
        self.store.service()
        if self.signing.key is not None:
            self.keeper.save()
        radio = self.radio
        for _ in range(_FLUSH_TRIES):
            radio.service()
            if radio.drained():
                break
            self._clock.sleep_ms(5)
        self._machine.reset()
