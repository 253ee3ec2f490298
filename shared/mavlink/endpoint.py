"""The vehicle's end of the MAVLink link.

``Endpoint.update(now_ms)`` is called by the firmware's scheduler: it reads
what the transport has, handles every complete frame, and sends what is due
(heartbeat at 1 Hz, telemetry streams at their ``SR_*`` rates, the next
parameters of a list request). Bytes move through an injected transport
with ``read_into(buf) -> n`` (0 or None when nothing waits) and
``write(buf)``: the firmware's UART radio driver on the board, a
pseudo-terminal bridge in tests.

Handled: ``HANDLERS`` (at the end) maps each message id the vehicle acts on
to its handler ``handler(ep, p)``, one module a protocol, as ArduPilot's
GCS_MAVLink; each handler checks its own fields (finite, in range:
``fields.py``) before anything reaches state, and refuses with its
protocol's answer:

- ``commands.py``: COMMAND_LONG and COMMAND_INT (COMMAND_ACK; a value that
  is no number or out of range DENIED, a refusal by the vehicle's state
  FAILED, as ArduPilot's);
- ``mode_protocol.py``: SET_MODE, DO_SET_MODE, DO_SET_STANDARD_MODE and the
  standard modes protocol (AVAILABLE_MODES, CURRENT_MODE: sent only once a
  ground station asked for either; to a ground station whose dialect lacks
  them a CURRENT_MODE is a frame whose sequence number pymavlink cannot
  read, and it counted the next frame's as a loss);
- ``param_protocol.py``: PARAM_REQUEST_LIST (streamed a few a cycle),
  PARAM_REQUEST_READ, PARAM_SET (a NaN or infinite value, or one the
  ``ParamTable`` refuses: the PARAM_VALUE echo carries the unchanged value,
  and a STATUSTEXT says why);
- ``mission.py``: the landing target as a mission (MISSION_ACK with the
  INVALID_PARAMn naming the field);
- ``position_input.py``: ATT_POS_MOCAP (a fix into ``fix``, ``fix_time_us``,
  ``fix_count`` and ``on_fix(fix)``) and SET_POSITION_TARGET_LOCAL_NED
  (the target): what is no place the vehicle can be is dropped, counted
  (``fixes_refused``, ``targets_refused``) and told by one STATUSTEXT
  every few seconds;
- ``streams.py``: REQUEST_DATA_STREAM (ArduPilot's stream groups onto the
  ``SR_*`` rates);
- ``signing.py``: SETUP_SIGNING;
- the log protocol: ``logs`` (``firmware/flightlog/transfer.py``);
- ``ftp.py``: FILE_TRANSFER_PROTOCOL, refused with the FTP protocol's NAK
  (no files are served: a ground station that asks, as MAVProxy does for
  the parameters, falls back at once instead of timing out);
- here: HEARTBEATs from the ground refresh ``gcs_last_ms`` (the
  ground-silence failsafe reads it), TIMESYNC requests are answered,
  RADIO_STATUS is kept in ``radio`` ([rssi, remrssi, txbuf, noise,
  remnoise, rxerrors, fixed]).

Sent: the heartbeat (1 Hz), the telemetry streams at their ``SR_*`` rates,
AUTOPILOT_VERSION and HOME_POSITION when asked for (``set_version``), a
STATUSTEXT over 50 bytes in chunks.

Loop load: SYS_STATUS ``load`` is ``Telemetry.load_permille``, the
scheduler's share of each slot spent working in permille (what ArduPilot
sends: its scheduler's load average x 1000). With it (the STATUS stream,
``SR_STATUS``, 1 Hz) goes NAMED_VALUE_INT ``SLOT_MAX`` (NAMED_VALUE_FLOAT
while the generated message table lacks the former): the longest slot in
microseconds since the previous report, from ``slot_max_us``, which the
firmware raises every slot and the report starts over.

Signing (docs/design/signing.md): when ``signing`` has a key, every frame
we send is signed, and every incoming frame must carry a valid, fresh
signature (``shared/mavlink/signing.py``: stream replay, new-stream age and
the bound ahead of our clock), except ``UNSIGNED_OK``: RADIO_STATUS and
RADIO, which the radio itself inserts unsigned (ArduPilot's list).
``signing.tick`` advances the signing clock every update. Refused frames
count in ``rejected``, ``unsigned`` and the ``Signing`` counters
(``bad``, ``replays``, ``future``); SYS_STATUS carries them
(``errors_count2``: unsigned and wrong-key frames, ``errors_count3``:
replayed, too old and far-future ones) and the first refusal each
``REFUSAL_TEXT_MS`` is told by STATUSTEXT, saying why.

SETUP_SIGNING (MAVProxy's ``signing setup``) sets the key (all zeros: off)
and moves the clock up to its ``initial_timestamp``; refused while armed.
With a key set it must itself be signed with that key (the general rule):
only the key's holder changes or removes it. Without a key it is taken
unsigned, as every command is then. ``on_setup_signing()`` (the firmware's
flash record) is called after.

Allocation: reading and framing allocate nothing (the writer keeps a view
of each frame length it sent); handling a frame unpacks one tuple of its
numbers (and boxes its floats). ``roboray-sim bench mavlink`` reports the bytes per frame.
"""

import struct
from array import array

from roboray.shared import modes as M
from roboray.shared import quat
from roboray.shared.mavlink import commands, ftp, mode_protocol, param_protocol, position_input, streams
from roboray.shared.mavlink import messages as msg
from roboray.shared.mavlink.frame import Writer
from roboray.shared.mavlink.mission import Mission
from roboray.shared.mavlink.parser import Parser
from roboray.shared.mavlink.signing import handle_setup_signing
from roboray.shared.mavlink.streams import N_STREAMS as _N_STREAMS
from roboray.shared.mavlink.streams import STREAM_PARAMS as _STREAM_PARAMS
from roboray.shared.mavlink.streams import S_ATTITUDE as _S_ATTITUDE
from roboray.shared.mavlink.streams import S_BATTERY as _S_BATTERY
from roboray.shared.mavlink.streams import S_POSITION as _S_POSITION
from roboray.shared.mavlink.streams import S_SENSORS as _S_SENSORS
from roboray.shared.mavlink.streams import S_SERVO as _S_SERVO
from roboray.shared.mavlink.streams import S_STATUS as _S_STATUS

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_TICKS_MASK = const(0x3FFFFFFF)   # time.ticks_ms() wraps at 2**30 on MicroPython
_TICKS_HALF = const(0x20000000)
_FRAMES_PER_UPDATE = const(1)     # frames handled or built per update (see Endpoint)
_CREDIT_MAX = const(512000)       # line credit (milli-bytes): at most this much sent at once
_ANSWERS = const(16)              # PARAM_VALUE answers waiting for their turn, at most
_HEARTBEAT_MS = const(1000)
_PERIOD_MAX_MS = const(1000000)   # a stream's period at most (1000 s: 0.001 Hz)

# The frames the streams are made of, one bit each, in the order they go out
# when several wait (the lowest bit first).
_F_HEARTBEAT = const(0x1)
_F_ATTITUDE = const(0x2)
_F_ATTITUDE_Q = const(0x4)
_F_STATUS = const(0x8)            # SYS_STATUS
_F_TIME = const(0x10)             # SYSTEM_TIME
_F_SLOT = const(0x20)             # SLOT_MAX
_F_LOCAL_POS = const(0x40)
_F_DEPTH = const(0x80)
_F_TARGET = const(0x100)
_F_PRESSURE = const(0x200)
_F_IMU = const(0x400)
_F_SERVO = const(0x800)
_F_WING1 = const(0x1000)
_F_WING2 = const(0x2000)
_F_WING3 = const(0x4000)
_F_WING4 = const(0x8000)
_F_BATTERY = const(0x10000)
_F_MISSION = const(0x20000)       # MISSION_CURRENT
_F_CURRENT_MODE = const(0x40000)
_F_AVAILABLE = const(0x80000)     # AVAILABLE_MODES, the next of those asked for
_F_POS_COV = const(0x100000)      # LOCAL_POSITION_NED_COV, with every other position frame
# A stream's telemetry is refreshed (on_refresh) with its first frame, which
# has its lowest bit: the others of the stream go out after it and use the same.
# each stream's frames, by stream number
_STREAM_FRAMES = (0x6, 0x1C0, 0x600, 0xF800, 0x10000, 0x20038)

_WING_NAMES = (b"wing1_deg", b"wing2_deg", b"wing3_deg", b"wing4_deg")
_MODE_NAMES = tuple(n.encode() for n in M.NAMES)   # AVAILABLE_MODES' mode_name, by mode
_DEPTH_NAME = b"depth_m"
_SLOT_NAME = b"SLOT_MAX"          # longest loop slot (us) since the last report
# SLOT_MAX goes as NAMED_VALUE_INT once the generated table has it (tools/mavgen.py
# MESSAGES); until then as NAMED_VALUE_FLOAT, which carries the microseconds exactly too.
_MSG_SLOT = getattr(msg, "MSG_NAMED_VALUE_INT", msg.MSG_NAMED_VALUE_FLOAT)
_SLOT_FMT = getattr(msg, "NAMED_VALUE_INT_FMT", msg.NAMED_VALUE_FLOAT_FMT)

#: Taken unsigned when a key is set: what the radio itself inserts
#: (ArduPilot's accept list: RADIO_STATUS, RADIO).
UNSIGNED_OK = (msg.MSG_RADIO_STATUS, 166)   # 166: RADIO (not in our table)
#: A refusal is told by STATUSTEXT at most once this often (ms).
REFUSAL_TEXT_MS = 10000
_WHY = ("", "wrong key", "replayed or old", "far-future")   # Signing.reason

#: AUTOPILOT_VERSION's capabilities: what the vehicle does (not FTP: ``ftp.py`` serves no files).
CAPABILITIES = (msg.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | msg.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | msg.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT | msg.MAV_PROTOCOL_CAPABILITY_MISSION_INT
                | msg.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
                | msg.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED)
# AUTOPILOT_VERSION up to product_id (messages.AUTOPILOT_VERSION_FMT's head),
# then flight_custom_version's 8 bytes at _VERSION_HASH
_VERSION_HEAD = "<QQIIIIHH"
_VERSION_HASH = const(36)
_TEXT_LEN = const(50)             # STATUSTEXT text bytes
_NAN = float("nan")
def ticks_diff(a, b):
    """a - b on a 2**30 wrapping millisecond clock, as time.ticks_diff."""
    return ((a - b + _TICKS_HALF) & _TICKS_MASK) - _TICKS_HALF


class Endpoint:
    """The vehicle's MAVLink endpoint.

    Parameters
    ----------
    transport:
        Object with ``read_into(buf) -> n`` and ``write(buf)``.
    params:
        The ``ParamTable``; must declare ``SYSID_THISMAV``, ``SYSID_MYGCS``
        and the ``SR_*`` rates of ``shared/param_defs.py``.
    modes:
        The ``Modes`` object (arming, mode changes, heartbeat flags).
    telemetry:
        The ``Telemetry`` object the firmware fills.
    signing:
        A ``Signing`` object (key set or not), or None.
    compid:
        Our component id (MAV_COMP_ID_AUTOPILOT1 by default).
    on_fix:
        Called with ``fix`` when an ATT_POS_MOCAP arrives.
    rx_size:
        Bytes read from the transport per update, at most: what arrives
        faster waits in the transport (the radio's UART buffer).
    on_refresh:
        ``on_refresh(k)`` is called before stream ``k`` (``_S_*``: 0
        attitude, 1 position, 2 sensors, 3 servo, 4 battery, 5 status)
        goes out, with its first frame, so that the firmware fills that
        part of ``telemetry`` only when it is about to be sent.
    frames_per_update:
        The update's budget, in units of one frame's work: a received frame
        parsed takes one, handling it one (a frame parsed when the budget
        is spent is handled in the next update), each answer one (answers
        always go); what is left goes to the heartbeat and the stream
        frames that are due, then to a parameter list's next values. What
        does not fit waits for the next update: received bytes in the
        transport, due frames in ``_pending`` (the streams keep their rates
        on average). One a 10 ms update is ~100 frames a second out, or 50
        in, more than the 57600-baud radio carries of either.

    Pacing: with a transport that has ``bytes_per_s`` (the radio), stream
    frames and a parameter list go out only while the line has carried what
    was sent before (a credit of at most ``_CREDIT_MAX`` bytes), so nothing
    is dropped for want of room; answers always go.
    """

    F_CURRENT_MODE = _F_CURRENT_MODE   # (for mode_protocol's requests)
    F_AVAILABLE = _F_AVAILABLE

    def __init__(self, transport, params, modes, telemetry, signing=None,
                 compid=msg.MAV_COMP_ID_AUTOPILOT1, on_fix=None, rx_size=128, on_refresh=None,
                 frames_per_update=_FRAMES_PER_UPDATE):
        if frames_per_update < 1:
            raise ValueError("frames_per_update must be >= 1, got %r" % (frames_per_update,))
        self.transport = transport
        self.params = params
        self.modes = modes
        self.t = telemetry
        self.signing = signing
        self.on_fix = on_fix
        idx = params.index("SYSID_THISMAV")
        gcs = params.index("SYSID_MYGCS")
        if idx < 0 or gcs < 0:
            raise ValueError("params must declare SYSID_THISMAV and SYSID_MYGCS")
        self._p_sysid = idx
        self._p_gcs = gcs
        self._p_rates = bytearray(_N_STREAMS)
        for k in range(_N_STREAMS):
            i = params.index(_STREAM_PARAMS[k])
            if i < 0:
                raise ValueError("params must declare %s" % _STREAM_PARAMS[k])
            self._p_rates[k] = i
        self.sysid = params.get_int(idx)
        self.parser = Parser(signing)
        self.writer = Writer(self.sysid, compid, signing)
        self._rx = bytearray(rx_size)
        self._rxv = memoryview(self._rx)
        self._rx_i = 0           # received bytes in _rx not yet parsed: _rx[_rx_i:_rx_n]
        self._rx_n = 0
        self.on_refresh = on_refresh
        self._held = False       # the parser holds a frame to handle in the next update
        self._read_last = False  # the last update read the transport
        # PARAM_VALUE answers (read, set) wait here for the next update's turn
        self._ans = array("H", [0] * _ANSWERS)
        self._ans_head = 0
        self._ans_n = 0
        self._frames = frames_per_update
        self._budget = 0         # frames this update may still build
        self._pending = 0        # _F_* frames due and not yet sent
        self._bps = getattr(transport, "bytes_per_s", 0)
        self._credit = _CREDIT_MAX   # milli-bytes the line can take now (with _bps)
        self._credit_ms = -1
        self._period_ms = array("l", [0] * _N_STREAMS)
        self._due_ms = array("l", [0] * _N_STREAMS)
        self._params_version = -1
        self._hb_due = 0
        # No heartbeat or stream is due before this tick (the earliest due
        # time when they were last looked at): most updates look no further.
        # Whatever moves a due time sets it to now.
        self._wake = 0
        self._param_next = -1   # next index to send for a list request, -1: none
        self._avail_next = 0    # AVAILABLE_MODES to send: indices _avail_next.._avail_last (0: none)
        self._avail_last = 0
        self._mode_sent = -1    # the mode CURRENT_MODE last said
        self._modes_asked = False   # a ground station asked for the standard modes' messages
        self._hb_odd = False    # CURRENT_MODE goes with every other heartbeat
        self._pos_odd = False   # LOCAL_POSITION_NED_COV goes with every other position frame
        self._euler = array("f", [0.0, 0.0, 0.0])
        self.now_ms = 0
        # for the firmware
        self.fix = array("f", [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
        self.fix_time_us = 0
        self.fix_count = 0
        self.target_count = 0
        self.gcs_last_ms = -1
        self.reboot_requested = False
        self.radio = array("H", [0] * 7)
        self.radio_count = 0
        #: Longest main-loop slot (us) since the last status report, -1: none
        #: yet. The firmware raises it every slot; the STATUS stream sends it
        #: (NAMED_VALUE_INT ``SLOT_MAX``) and starts it over.
        self.slot_max_us = -1
        # counters
        self.rejected = 0
        self.fixes_refused = 0        # ATT_POS_MOCAP not a place the vehicle can be (position_input)
        self.targets_refused = 0      # SET_POSITION_TARGET_LOCAL_NED refused (position_input)
        self._input_text_ms = -1      # when a position input refusal was last told
        self.unsigned = 0             # unsigned frames refused (a key is set)
        self._refusal_ms = -1         # when a refusal was last told
        self.on_setup_signing = None  # called after SETUP_SIGNING changed key or clock
        self.handled = 0
        self.commands = 0
        self._text_id = 0             # the last chunked STATUSTEXT's id
        #: AUTOPILOT_VERSION's flight_sw_version and flight_custom_version
        #: (``set_version``; 0 and zeros: unknown)
        self.sw_version = 0
        self.sw_hash = bytes(8)
        #: The mission protocol (the landing target as a mission).
        self.mission = Mission(self)
        #: The log protocol (``firmware/flightlog/transfer.LogTransfer``), set by
        #: the firmware; None: LOG_* requests go unanswered.
        self.logs = None
        #: ``on_text(text)``: every STATUSTEXT sent, for the flight log (MSG).
        self.on_text = None

    # ------------------------------------------------------------- driving
    def update(self, now_ms):
        """Read and handle what arrived, then send what is due."""
        now = now_ms & _TICKS_MASK
        self.now_ms = now
        if self.signing is not None:
            self.signing.tick(now)
        self._budget = self._frames
        # a frame parsed in the last update is handled first
        p = self.parser
        if self._held:
            self._held = False
            self._budget -= 1
            self._handle(p)
        if self._budget <= 0:
            return      # (what fell due is looked at in the next update)
        # what is due
        if self.params.version != self._params_version:
            self._load_rates()
        if self._modes_asked and self.modes.mode != self._mode_sent:
            self._pending |= _F_CURRENT_MODE
        # ticks_diff(now, _wake) >= 0, inline: the wrapped difference is below half the period
        if (now - self._wake) & _TICKS_MASK < _TICKS_HALF:
            self._due_streams(now)
        if self.mission.receiving:
            self.mission.tick(now)      # an upload's item late: asked again
        # Sending and reading take turns while there is something to send:
        # an update that follows one that read sends and does not look at
        # the transport (what arrived waits there one update more); one that
        # reads may send too. So a burst of due frames neither holds the
        # received ones back nor costs a read each.
        if self._read_last and (self._pending or self._param_next >= 0 or self._ans_n or self._bulk()) and self._line_free():
            self._read_last = False
            self._send_due()
            return
        self._read_last = True
        # what is left of the last read, else one read, parsed while the
        # budget lasts (a frame parsed takes one, handling it one)
        i = self._rx_i
        n = self._rx_n
        if i >= n:
            i = 0
            n = self.transport.read_into(self._rx)
            if not n:
                n = 0
        rxv = self._rxv
        while i < n:
            i = p.feed(rxv, i, n)
            if p.ready:
                self._budget -= 1
                if self._budget <= 0:
                    self._held = True
                    break
                self._budget -= 1
                self._handle(p)
                if self._budget <= 0:
                    break
        self._rx_i = i
        self._rx_n = n
        if self._budget > 0 and (self._pending or self._param_next >= 0 or self._ans_n or self._bulk()) and self._line_free():
            self._send_due()

    def _line_free(self):
        """Whether the line has carried what was sent (always, without ``bytes_per_s``)."""
        bps = self._bps
        if not bps:
            return True
        # the line's credit: what it carried since it was last reckoned
        now = self.now_ms
        if self._credit_ms >= 0:
            c = self._credit + ((now - self._credit_ms) & _TICKS_MASK) * bps
            self._credit = c if c < _CREDIT_MAX else _CREDIT_MAX
        self._credit_ms = now
        return self._credit > 0

    def _send_due(self):
        """Parameter values asked for, due stream frames, then a parameter list's
        next values, while the budget and the line allow."""
        while self._ans_n and self._budget > 0:
            h = self._ans_head
            self._ans_head = (h + 1) % _ANSWERS
            self._ans_n -= 1
            self.send_param(self._ans[h])
        if self._pending:
            self._send_pending()
        if self._param_next >= 0:
            count = self.params.count()
            while self._budget > 0 and (self._credit > 0 or not self._bps):
                i = self._param_next
                if i >= count:
                    self._param_next = -1
                    break
                self.send_param(i)
                self._param_next = i + 1
        logs = self.logs
        if logs is not None and logs.sending and self._param_next < 0:
            logs.send(self)

    def _bulk(self):
        """Whether log entries or data wait to go (a download: second to the parameter list)."""
        logs = self.logs
        return logs is not None and logs.sending

    def _due_streams(self, now):
        """Mark the heartbeat and the streams that are due; sets ``_wake`` to the next due time."""
        # ticks_diff written out: ((a - b + _TICKS_HALF) & _TICKS_MASK) - _TICKS_HALF
        pend = self._pending
        hb = self._hb_due
        soonest = ((hb - now + _TICKS_HALF) & _TICKS_MASK) - _TICKS_HALF
        if soonest <= 0:
            hb = (now + _HEARTBEAT_MS) & _TICKS_MASK
            self._hb_due = hb
            soonest = _HEARTBEAT_MS
            pend |= _F_HEARTBEAT
            odd = not self._hb_odd
            self._hb_odd = odd
            if odd and self._modes_asked:
                pend |= _F_CURRENT_MODE
        wake = hb
        due = self._due_ms
        periods = self._period_ms
        for k in range(_N_STREAMS):
            period = periods[k]
            if period > 0:
                d = due[k]
                left = ((d - now + _TICKS_HALF) & _TICKS_MASK) - _TICKS_HALF
                if left <= 0:
                    # the next one a period after this one was due, not after
                    # now: a frame held back a slot or two keeps the average
                    # rate; more than a period behind, from now
                    left += period
                    if left > 0:
                        d = (d + period) & _TICKS_MASK
                    else:
                        d = (now + period) & _TICKS_MASK
                        left = period
                    due[k] = d
                    pend |= _STREAM_FRAMES[k]
                    if k == _S_POSITION:
                        # the position with its variances at half the
                        # stream's rate (1 Hz by default: 237 bytes, 4 % of
                        # a 57600-baud radio)
                        odd = not self._pos_odd
                        self._pos_odd = odd
                        if odd:
                            pend |= _F_POS_COV
                if left < soonest:
                    soonest = left
                    wake = d
        self._pending = pend
        # (a due time half the tick period away reads as past: look every time then)
        self._wake = wake if soonest > 0 else now

    def _send_pending(self):
        """Frames that wait, the lowest bit first, while the update's budget and the line allow
        (read again after each: a frame may set its bit again, AVAILABLE_MODES while more are due)."""
        bps = self._bps
        while self._pending and self._budget > 0 and (self._credit > 0 or not bps):
            pend = self._pending
            f = pend & -pend
            self._pending = pend ^ f
            self._send_frame(f)

    def _load_rates(self):
        self._params_version = self.params.version
        for k in range(_N_STREAMS):
            rate = self.params.get(self._p_rates[k])
            period = 1000.0 / rate if rate > 0.0 else 0.0
            # a rate of 1e-24 Hz (a PARAM_SET, an interval of 1e30 us) is a
            # period array('l') cannot hold: OverflowError ended the link task
            self._period_ms[k] = int(period) if period < _PERIOD_MAX_MS else _PERIOD_MAX_MS
        self._wake = self.now_ms

    def _send(self, msgid):
        w = self.writer
        n = w.finish(msgid)
        self.transport.write(w.view(n))
        self._budget -= 1
        if self._bps:
            self._credit -= n * 1000

    # ------------------------------------------------------------ handling
    def _handle(self, p):
        mid = p.msgid
        s = self.signing
        if s is not None and s.key is not None and not p.sig_ok and mid != msg.MSG_RADIO_STATUS and mid != 166:
            self._refused(p, s)
            return
        self.handled += 1
        h = HANDLERS.get(mid)
        if h is not None:
            h(self, p)

    def _refused(self, p, s):
        """Count a frame signing refused; tell the first one each REFUSAL_TEXT_MS."""
        self.rejected += 1
        if not p.signed:
            self.unsigned += 1
        last = self._refusal_ms
        if last >= 0 and ticks_diff(self.now_ms, last) < REFUSAL_TEXT_MS:
            return
        self._refusal_ms = self.now_ms
        why = "unsigned" if not p.signed else _WHY[s.reason]
        self.send_text(msg.MAV_SEVERITY_WARNING, "signing: %s msg %d from %d refused (%d)" % (
            why, p.msgid, p.sysid, self.rejected))

    def _for_us(self, target_system, target_component):
        return (target_system == self.sysid or target_system == 0) and (
            target_component == self.writer.compid or target_component == 0)

    # ----------------------------------------------------------- parameters
    def _answer_param(self, i):
        # the PARAM_VALUE of a read or a set goes out in the next update's
        # turn, first of what waits (now, if too many wait already)
        n = self._ans_n
        if n >= _ANSWERS:
            self.send_param(i)
            return
        self._ans[(self._ans_head + n) % _ANSWERS] = i
        self._ans_n = n + 1

    def send_param(self, i):
        params = self.params
        w = self.writer
        struct.pack_into(msg.PARAM_VALUE_FMT, w.buf, w.payload, params.get(i), params.count(), i,
                         params.name_bytes(i), params.type(i))
        self._send(msg.MSG_PARAM_VALUE)

    def _send_once(self, mid):
        """AUTOPILOT_VERSION or HOME_POSITION, now (asked for)."""
        w = self.writer
        b = w.buf
        o = w.payload
        if mid == msg.MSG_AUTOPILOT_VERSION:
            w.clear(msg.AUTOPILOT_VERSION_LEN)
            struct.pack_into(_VERSION_HEAD, b, o, CAPABILITIES, 0, self.sw_version, 0, 0, 0, 0, 0)
            b[o + _VERSION_HASH:o + _VERSION_HASH + 8] = self.sw_hash
            self._send(msg.MSG_AUTOPILOT_VERSION)
        else:
            # the release point: the local frame's origin (no global position:
            # latitude, longitude and altitude 0), attitude unrotated
            struct.pack_into(msg.HOME_POSITION_FMT, b, o, 0, 0, 0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
                             0.0, 0.0, 0.0, 0)
            self._send(msg.MSG_HOME_POSITION)

    def set_version(self, version, revision):
        """AUTOPILOT_VERSION's from the build (``build_info.VERSION``, ``REVISION``):
        ``flight_sw_version`` major, minor, patch and type (DEV for a dirty or
        unknown revision, OFFICIAL for a clean commit) and the revision's
        first 8 characters as ``flight_custom_version``."""
        v = 0
        shift = 24
        for part in version.split(".")[:3]:
            digits = ""
            for c in part:
                if "0" <= c <= "9":
                    digits += c
                else:
                    break
            v |= (int(digits) & 0xFF if digits else 0) << shift
            shift -= 8
        dev = revision == "unknown" or revision.endswith("-dirty") or not revision
        self.sw_version = v | (msg.FIRMWARE_VERSION_TYPE_DEV if dev else msg.FIRMWARE_VERSION_TYPE_OFFICIAL)
        h = bytearray(8)
        r = revision.encode()[:8] if revision != "unknown" else b""
        h[0:len(r)] = r
        self.sw_hash = bytes(h)

    def _set_target(self, n, e, d):
        """The target, as given (the callers check it: ``position_input.set_target``)."""
        t = self.t
        t.target_ned[0] = n
        t.target_ned[1] = e
        t.target_ned[2] = d
        t.has_target = True
        self.target_count += 1

    # ------------------------------------------------------------- answers
    def _ack_result(self, p, cmd, result):
        if result[0]:
            self._ack(p, cmd, msg.MAV_RESULT_ACCEPTED, 0)
        else:
            self._refuse(p, cmd, msg.MAV_RESULT_FAILED, result[1])   # (ArduPilot's: FAILED)

    def _refuse(self, p, cmd, mav_result, reason):
        code = M.REASONS.index(reason) if reason in M.REASONS else 255
        self._ack(p, cmd, mav_result, code)
        self.send_text(msg.MAV_SEVERITY_WARNING, reason)

    def _ack(self, p, cmd, result, param2):
        w = self.writer
        struct.pack_into(msg.COMMAND_ACK_FMT, w.buf, w.payload, cmd, result, 0, param2, p.sysid, p.compid)
        self._send(msg.MSG_COMMAND_ACK)

    def send_text(self, severity, text):
        """STATUSTEXT: up to 50 bytes of UTF-8 in one; a longer text in chunks of
        50 as MAVLink 2 allows (one ``id``, ``chunk_seq`` 0, 1, ...; the last
        chunk shorter than 50 bytes, an empty one after an exact multiple)."""
        # "50s" pads and cuts in C: indexing a str character by character is
        # O(i) on MicroPython (UTF-8), a 30-character text took ~6 ms so
        w = self.writer
        data = text.encode()
        if self.on_text is not None:
            self.on_text(data)
        n = len(data)
        if n <= _TEXT_LEN or w.mavlink1:
            struct.pack_into(msg.STATUSTEXT_FMT, w.buf, w.payload, severity, data, 0, 0)
            self._send(msg.MSG_STATUSTEXT)
            return
        tid = self._text_id % 0xFFFF + 1     # 1..65535 (0: not chunked)
        self._text_id = tid
        k = 0
        seq = 0
        while k <= n:
            struct.pack_into(msg.STATUSTEXT_FMT, w.buf, w.payload, severity, data[k:k + _TEXT_LEN], tid, seq)
            self._send(msg.MSG_STATUSTEXT)
            k += _TEXT_LEN
            seq += 1

    # ------------------------------------------------------------ telemetry
    def _heartbeat_now(self):
        self._pending &= ~_F_HEARTBEAT
        self._hb_due = (self.now_ms + _HEARTBEAT_MS) & _TICKS_MASK
        self._wake = self.now_ms
        self.send_heartbeat()

    def send_heartbeat(self):
        m = self.modes
        w = self.writer
        struct.pack_into(msg.HEARTBEAT_FMT, w.buf, w.payload, m.custom_mode(), msg.MAV_TYPE_SUBMARINE,
                         msg.MAV_AUTOPILOT_GENERIC, m.base_mode(), m.system_status(), 3)
        self._send(msg.MSG_HEARTBEAT)

    def _send_stream(self, k):
        """All of stream ``k``'s frames, now (a request's answer); its next one a period on."""
        f = _STREAM_FRAMES[k]
        self._pending &= ~f
        period = self._period_ms[k]
        if period > 0:
            self._due_ms[k] = (self.now_ms + period) & _TICKS_MASK
        b = 1
        while b <= f:
            if b & f:
                self._send_frame(b)
            b <<= 1

    def _send_frame(self, f):
        """The stream frame of bit ``f`` (``_F_*``)."""
        # the most frequent first; a stream's first frame has the firmware
        # fill its telemetry just before it goes out (on_refresh)
        t = self.t
        w = self.writer
        b = w.buf
        o = w.payload
        now = self.now_ms
        refresh = self.on_refresh
        if f & 0xF000:   # _F_WING1.._F_WING4
            i = 0 if f == _F_WING1 else (1 if f == _F_WING2 else (2 if f == _F_WING3 else 3))
            struct.pack_into(msg.NAMED_VALUE_FLOAT_FMT, b, o, now, t.servo_deg[i], _WING_NAMES[i])
            self._send(msg.MSG_NAMED_VALUE_FLOAT)
        elif f == _F_ATTITUDE:
            if refresh is not None:
                refresh(_S_ATTITUDE)
            e = self._euler
            quat.to_euler(e, t.q)
            r = t.rates
            struct.pack_into(msg.ATTITUDE_FMT, b, o, now, e[0], e[1], e[2], r[0], r[1], r[2])
            self._send(msg.MSG_ATTITUDE)
        elif f == _F_ATTITUDE_Q:
            q = t.q
            r = t.rates
            struct.pack_into(msg.ATTITUDE_QUATERNION_FMT, b, o, now, q[0], q[1], q[2], q[3],
                             r[0], r[1], r[2], 0.0, 0.0, 0.0, 0.0)
            self._send(msg.MSG_ATTITUDE_QUATERNION)
        elif f == _F_STATUS:
            if refresh is not None:
                refresh(_S_STATUS)
            bat = t.battery
            mv = int(bat[0] * 1000.0)
            if mv > 65534:
                mv = 65534
            par = self.parser
            # drop_rate_comm as MAVLink defines it (and the MAVLink C library
            # counts, packet_rx_drop_count): frames corrupted on reception, of
            # all received. Sequence gaps are not it: senders that share an
            # identity (two ground programs at 255/190) jump each other's numbers.
            bad = par.crc_errors + par.bad_header
            drop = 0
            if bad > 0:
                drop = (bad * 10000) // (par.frames + bad)
            sg = self.signing
            auth = 0     # signing refusals: unsigned and wrong key; replayed, old and far-future
            stale = 0
            if sg is not None:
                auth = (self.unsigned + sg.bad) & 0xFFFF
                stale = (sg.replays + sg.future) & 0xFFFF
            # the fence's health bit set without a fence, as ArduPilot's (a
            # ground station reads it clear as a breach)
            struct.pack_into(msg.SYS_STATUS_FMT, b, o, t.sensors_present, t.sensors_enabled,
                             t.sensors_health | msg.MAV_SYS_STATUS_GEOFENCE,
                             t.load_permille, mv, _clamp16(bat[1] * 100.0), drop,
                             (par.crc_errors + par.bad_header) & 0xFFFF, t.failsafe_flags & 0xFFFF,
                             auth, stale, 0, int(bat[2] * 100.0) if bat[2] >= 0.0 else -1, 0, 0, 0)
            self._send(msg.MSG_SYS_STATUS)
        elif f == _F_TIME:
            struct.pack_into(msg.SYSTEM_TIME_FMT, b, o, 0, now)
            self._send(msg.MSG_SYSTEM_TIME)
        elif f == _F_SLOT:
            slot = self.slot_max_us
            if slot >= 0:
                struct.pack_into(_SLOT_FMT, b, o, now, slot, _SLOT_NAME)
                self._send(_MSG_SLOT)
                self.slot_max_us = -1
        elif f == _F_LOCAL_POS:
            if refresh is not None:
                refresh(_S_POSITION)
            p = t.pos_ned
            v = t.vel_ned
            struct.pack_into(msg.LOCAL_POSITION_NED_FMT, b, o, now, p[0], p[1], p[2], v[0], v[1], v[2])
            self._send(msg.MSG_LOCAL_POSITION_NED)
        elif f == _F_DEPTH:
            struct.pack_into(msg.NAMED_VALUE_FLOAT_FMT, b, o, now, t.env[0], _DEPTH_NAME)
            self._send(msg.MSG_NAMED_VALUE_FLOAT)
        elif f == _F_TARGET:
            if t.has_target:
                g = t.target_ned
                # type_mask 0xFF8: position only (velocity, acceleration, yaw ignored)
                struct.pack_into(msg.POSITION_TARGET_LOCAL_NED_FMT, b, o, now, g[0], g[1], g[2],
                                 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0xDF8, msg.MAV_FRAME_LOCAL_NED)
                self._send(msg.MSG_POSITION_TARGET_LOCAL_NED)
        elif f == _F_PRESSURE:
            if refresh is not None:
                refresh(_S_SENSORS)
            env = t.env
            struct.pack_into(msg.SCALED_PRESSURE_FMT, b, o, now, env[1] * 0.01, 0.0,
                             _clamp16(env[2] * 100.0), 0)
            self._send(msg.MSG_SCALED_PRESSURE)
        elif f == _F_IMU:
            m = t.imu
            # mG, mrad/s, mgauss (SCALED_IMU units)
            struct.pack_into(msg.SCALED_IMU_FMT, b, o, now,
                             _clamp16(m[0] * 101.97162), _clamp16(m[1] * 101.97162), _clamp16(m[2] * 101.97162),
                             _clamp16(m[3] * 1000.0), _clamp16(m[4] * 1000.0), _clamp16(m[5] * 1000.0),
                             _clamp16(m[6] * 1000.0), _clamp16(m[7] * 1000.0), _clamp16(m[8] * 1000.0),
                             _clamp16(t.env[2] * 100.0))
            self._send(msg.MSG_SCALED_IMU)
        elif f == _F_SERVO:
            if refresh is not None:
                refresh(_S_SERVO)
            s = t.servo_us
            # time_usec wraps at 2**20 ms (1048 s): (now * 1000) & 0xFFFFFFFF
            # made a long int on the board each frame; below 2**30 it is a small one
            struct.pack_into(msg.SERVO_OUTPUT_RAW_FMT, b, o, (now & 0xFFFFF) * 1000,
                             s[0], s[1], s[2], s[3], 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0)
            self._send(msg.MSG_SERVO_OUTPUT_RAW)
        elif f == _F_HEARTBEAT:
            self.send_heartbeat()
        elif f == _F_CURRENT_MODE:
            m = self.modes
            mode = m.mode
            self._mode_sent = mode
            struct.pack_into(msg.CURRENT_MODE_FMT, b, o, M.CUSTOM[mode], M.CUSTOM[m.intended], M.STANDARD[mode])
            self._send(msg.MSG_CURRENT_MODE)
        elif f == _F_AVAILABLE:
            i = self._avail_next
            mode = M.MODES[i - 1]
            struct.pack_into(msg.AVAILABLE_MODES_FMT, b, o, M.CUSTOM[mode], 0, len(M.MODES), i, M.STANDARD[mode],
                             _MODE_NAMES[mode])
            self._send(msg.MSG_AVAILABLE_MODES)
            if i < self._avail_last:
                self._avail_next = i + 1
                self._pending |= _F_AVAILABLE
            else:
                self._avail_next = 0
        elif f == _F_BATTERY:
            if refresh is not None:
                refresh(_S_BATTERY)
            bat = t.battery   # (every field packed: nothing to clear)
            mv = int(bat[0] * 1000.0)
            if mv > 65534:
                mv = 65534
            struct.pack_into(msg.BATTERY_STATUS_FMT, b, o, -1, -1, 0x7FFF,
                             mv, 0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF,
                             _clamp16(bat[1] * 100.0), 0, 0, 0,
                             int(bat[2] * 100.0) if bat[2] >= 0.0 else -1, 0, 0, 0, 0, 0, 0, 0, 0)
            self._send(msg.MSG_BATTERY_STATUS)
        elif f == _F_MISSION:
            self.mission.send_current()
        elif f == _F_POS_COV:
            # after LOCAL_POSITION_NED, whose refresh it uses: the position
            # with its variances (Telemetry.var_ned, var_dz), north and east
            # growing while the position is dead-reckoned without fixes, so
            # a ground station sees how far to trust a position reckoned
            # below the radio's reach
            p = t.pos_ned
            v = t.vel_ned
            r = t.var_ned
            z = t.var_dz
            # One pack of the whole frame: the covariance is the upper
            # triangle of the 9x9 of position, velocity and acceleration, row
            # by row, zero but its diagonal; accelerations are not estimated
            # (NaN). Packed a float a call it took 2.1 ms of the board's
            # 10 ms slot once a second (45 formats parsed): the longest link
            # call (docs/benchmarks.md, stop 28). time_usec wraps at 2**20 ms,
            # a small int (as SERVO_OUTPUT_RAW's).
            struct.pack_into(msg.LOCAL_POSITION_NED_COV_FMT, b, o, (now & 0xFFFFF) * 1000,
                             p[0], p[1], p[2], v[0], v[1], v[2], _NAN, _NAN, _NAN,
                             r[0], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,   # north
                             r[1], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,        # east
                             z[0], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,             # down
                             r[2], 0.0, 0.0, 0.0, 0.0, 0.0,                  # vn
                             r[3], 0.0, 0.0, 0.0, 0.0,                       # ve
                             z[1], 0.0, 0.0, 0.0,                            # vd
                             _NAN, 0.0, 0.0,                                 # an
                             _NAN, 0.0,                                      # ae
                             _NAN,                                           # ad
                             msg.MAV_ESTIMATOR_TYPE_AUTOPILOT)
            self._send(msg.MSG_LOCAL_POSITION_NED_COV)


def _clamp16(x):
    v = int(x)
    if v > 32767:
        return 32767
    if v < -32768:
        return -32768
    return v


# ---------------------------------------------------------------- the link's own
def _heartbeat(ep, p):
    """A HEARTBEAT from our ground station refreshes ``gcs_last_ms`` (the
    ground-silence failsafe reads it)."""
    if p.sysid == ep.params.get_int(ep._p_gcs):
        if ep.gcs_last_ms < 0 or ticks_diff(ep.now_ms, ep.gcs_last_ms) > 2000:
            ep._heartbeat_now()  # a ground station (re)appeared: answer at once
        ep.gcs_last_ms = ep.now_ms


def _timesync(ep, p):
    """A TIMESYNC request (tc1 0) is answered with our clock (integers only)."""
    tc1, ts1 = struct.unpack_from("<qq", p.payload, 0)
    if tc1 == 0:
        w = ep.writer
        struct.pack_into(msg.TIMESYNC_FMT, w.buf, w.payload, ep.now_ms * 1000000, ts1)
        ep._send(msg.MSG_TIMESYNC)


def _radio_status(ep, p):
    """RADIO_STATUS from the radio, kept in ``radio`` (integers only)."""
    pl = p.payload
    r = ep.radio
    r[0] = pl[4]
    r[1] = pl[5]
    r[2] = pl[6]
    r[3] = pl[7]
    r[4] = pl[8]
    r[5] = pl[0] | (pl[1] << 8)
    r[6] = pl[2] | (pl[3] << 8)
    ep.radio_count += 1


def _mission(ep, p):
    ep.mission.handle(p)


def _logs(ep, p):
    if ep.logs is not None:
        ep.logs.handle(p)


#: Every message the endpoint acts on, message id -> ``handler(ep, p)``; the
#: handler checks its own fields (``fields.py``) before anything reaches state.
HANDLERS = {
    msg.MSG_HEARTBEAT: _heartbeat,
    msg.MSG_COMMAND_LONG: commands.handle,
    msg.MSG_COMMAND_INT: commands.handle,
    msg.MSG_PARAM_REQUEST_LIST: param_protocol.handle_request_list,
    msg.MSG_PARAM_REQUEST_READ: param_protocol.handle_request_read,
    msg.MSG_PARAM_SET: param_protocol.handle_set,
    msg.MSG_SET_POSITION_TARGET_LOCAL_NED: position_input.handle_set_position_target,
    msg.MSG_ATT_POS_MOCAP: position_input.handle_att_pos_mocap,
    msg.MSG_TIMESYNC: _timesync,
    msg.MSG_SETUP_SIGNING: handle_setup_signing,
    msg.MSG_RADIO_STATUS: _radio_status,
    msg.MSG_SET_MODE: mode_protocol.handle_set_mode,
    msg.MSG_REQUEST_DATA_STREAM: streams.handle_request_data_stream,
    msg.MSG_FILE_TRANSFER_PROTOCOL: ftp.handle,
}
for _mid in (msg.MSG_MISSION_ITEM, msg.MSG_MISSION_REQUEST, msg.MSG_MISSION_SET_CURRENT,
             msg.MSG_MISSION_REQUEST_LIST, msg.MSG_MISSION_COUNT, msg.MSG_MISSION_CLEAR_ALL,
             msg.MSG_MISSION_ACK, msg.MSG_MISSION_REQUEST_INT, msg.MSG_MISSION_ITEM_INT):
    HANDLERS[_mid] = _mission
for _mid in (msg.MSG_LOG_REQUEST_LIST, msg.MSG_LOG_REQUEST_DATA, msg.MSG_LOG_ERASE, msg.MSG_LOG_REQUEST_END):
    HANDLERS[_mid] = _logs
