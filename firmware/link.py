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
- arm, disarm and mode commands go to ``shared/modes.py`` (the endpoint's
  doing, through the arming and mode checks of ``firmware/failsafe.py``);
- a reboot (PREFLIGHT_REBOOT_SHUTDOWN, refused while armed) saves the
  parameters if they changed, lets the COMMAND_ACK leave and resets the
  board (``machine.reset()``).
"""

import struct
from array import array

from roboray.shared.mavlink import messages as msg
from roboray.shared.mavlink.endpoint import Endpoint

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_VELOCITY_BITS = const(0x38)
_FLUSH_TRIES = const(40)    # x 5 ms: time the COMMAND_ACK of a reboot gets to leave


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
            if vx - vx == 0 and vy - vy == 0 and vz - vz == 0:   # finite
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
        self.ep = VehicleEndpoint(radio, params, modes, telemetry, on_fix=self._on_fix,
                                  on_refresh=reporter.refresh)

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
        ep.update(self._clock.ticks_ms())
        if ep.reboot_requested:
            ep.reboot_requested = False
            self.reboot()

    def send_text(self, severity, text):
        self.ep.send_text(severity, text)

    def reboot(self):
        """Save changed parameters, let the radio drain, reset the board."""
        self.ep.send_text(msg.MAV_SEVERITY_INFO, "rebooting")
        self.store.service()
        radio = self.radio
        for _ in range(_FLUSH_TRIES):
            radio.service()
            if not radio.queued():
                break
            self._clock.sleep_ms(5)
        self._machine.reset()
