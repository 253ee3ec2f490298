"""The dive's on-board log: what is recorded, how often, and when it goes to flash.

Radio barely carries through water, so the record a researcher can count on
is the one the vehicle keeps. ``FlightLog`` writes ArduPilot DataFlash
records (``dataflash.py``) into a RAM ring and moves them to a numbered
``.BIN`` file (``files.py``) only when a flash write cannot hurt.

Why RAM first: writing the Pico 2's flash suspends execution from it, and
littlefs erases a 4 kB sector (45 ms) for each new block it fills, so an
append in a flight slot would be a 50 ms stall. Records therefore go to
flash only while the vehicle is **disarmed**, or armed and **resting on
the bottom** (the estimator's speed, low-passed over ``STILL_TAU_S``, under
``STILL_MPS`` on every axis for ``STILL_S``, deeper than ``REST_DEPTH_M``: armed at the surface it may be
let go at any moment), one chunk of at most
``CHUNK`` bytes every ``FLUSH_EVERY`` calls, each announced to the
scheduler as the planned stall it is (``expect_delay``, the twin charges
the same stall). Arming writes nothing: the next dive's log is prepared on
deck (disarmed and still: its header and parameters on flash, a few
records a call), so a dive that never comes to rest still leaves a
readable log; parameters changed after it was prepared are recorded again
at arming. A log started by a reset in the water waits for the vehicle to
rest. A prepared log no dive used is used again by the next one.

What the ring holds (default ``LOG_FILE_BUFSIZE`` 80 kB, every record
enabled): the records below come at ~2.4 kB/s, ~25 s of dive at full rate
until a quarter is left; then the recording thins (IMU to 5 Hz; MAG, RCOU
and WING stop; ATT stays at 25 Hz: ~1.1 kB/s) for ~18 s more. A default
passive drop of the buildable vehicle, armed at 9 s and resting from
about 43 s, lost 296 records with 48 kB and none with 64, 80 or 96 kB
(``roboray-sim sil --scenario passive-drop --vehicle
sim/vehicles/buildable.py --param LOG_FILE_BUFSIZE=N --board-fs DIR``);
80 keeps a margin for a slower dive. When full, new
records are dropped (never old ones), counted (PM ``Drop``) and told in a
MSG at the next flush. Events (MODE, MSG, EV, ERR, FIX) are never thinned.
Why not more: the heap must hold the loop's garbage between two
collections beside the firmware's live objects, and the collector scans
the ring (~0.13 ms a kB on a Pico 2). With stock MicroPython's boxed
floats an 80 kB ring left too little room (an allocation collected in the
middle of a task: a 63 ms stall, the IMU's FIFO overrun); RoboRay's build
keeps floats off the heap, and on rp2350-emu 96 kB gave 0 overruns (the
buildable passive drop and target-landing), collections up to 57.8 ms
against 50.0 ms with 48 kB (``docs/design/flight-log.md``).

Records and rates (the log task runs at 50 Hz; ``LOG_BITMASK`` bit in
brackets):

======  ======  =============================================================
ATT     25 Hz   roll, pitch, yaw (deg) [0]: the wings move the attitude
                within ~0.2 s, so 25 Hz resolves a manoeuvre
IMU     25 Hz   gyro (rad/s), accelerometer (m/s/s): the mean of the 104 Hz
                FIFO over the last slot [1]
MAG      5 Hz   field (Gauss) [2]: the heading changes over seconds
BARO    10 Hz   Alt (m, minus the depth), pressure (Pa), temperature [3]
RCOU     5 Hz   servo pulses (us) [4]
WING     5 Hz   commanded wing angles (deg) [4]: the servos report no angle,
                so the command is what is known
EST     10 Hz   position, velocity (NED, m, m/s), target and the horizontal
                position's and velocity's variances per axis (PV m^2, VV
                m^2/s^2: they grow while the position is dead-reckoned
                without fixes) [5]: the glide settles in seconds
PM       1 Hz   overruns, slots, longest slot, load, drops [6] (no free
                heap: ``gc.mem_free()`` walks the whole heap, ~23 ms on a Pico 2)
FIX     each    a position fix as it arrives: N, E, D, its age [7]
MODE, MSG, EV, ERR, PARM  as they happen: modes, texts, arming and rest,
                failsafes raised and cleared, every parameter at arming
======  ======  =============================================================
"""

import struct
from array import array

from roboray.firmware.flightlog import dataflash as df
from roboray.firmware.flightlog.dataflash import HEAD1, HEAD2, Record
from roboray.shared import modes as modes_mod
from roboray.shared import quat
from roboray.shared.params import TYPE_INT32, TYPE_UINT8

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

PARAMS = (
    ("LOG_BITMASK", TYPE_INT32, 255, 0, 255),        # records kept (bits above)
    ("LOG_FILE_BUFSIZE", TYPE_UINT8, 80, 8, 160),    # kB of RAM for the ring
    ("LOG_DISARMED", TYPE_UINT8, 0, 0, 1),           # 1: log while disarmed too
)

ATT = Record(150, "ATT", "QccC", "TimeUS,Roll,Pitch,Yaw", "sddh", "FBBB")
IMU = Record(151, "IMU", "QBffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ", "s#EEEooo", "F-000000")
MAG = Record(152, "MAG", "QBfff", "TimeUS,I,MagX,MagY,MagZ", "s#GGG", "F-000")
BARO = Record(153, "BARO", "QBfff", "TimeUS,I,Alt,Press,Temp", "s#mPO", "F-000")
RCOU = Record(154, "RCOU", "QHHHH", "TimeUS,C1,C2,C3,C4", "sYYYY", "F0000")
WING = Record(155, "WING", "Qcccc", "TimeUS,Cmd1,Cmd2,Cmd3,Cmd4", "sdddd", "FBBBB")
EST = Record(156, "EST", "Qffffffffff", "TimeUS,PN,PE,PD,VN,VE,VD,TN,TE,PV,VV", "smmmnnnmm--", "F0000000000")
PM = Record(157, "PM", "QHHIHH", "TimeUS,NLon,NLoop,MaxT,Load,Drop", "s--s%-", "F--FA-")
FIX = Record(158, "FIX", "QfffI", "TimeUS,N,E,D,Age", "smmms", "F000C")
# Mode is RoboRay's name of the mode, ModeNum HEARTBEAT's custom_mode (the
# ArduSub number ground stations map). A name, not ArduPilot's one-byte
# number: pymavlink's DFReader shows a text Mode as it is (mavflightmodes.py,
# MAVExplorer), where it would map a number through the table of the
# vehicle type it guesses, ArduPlane's for a log that names no ArduPilot
# vehicle (QLOITER, TRAINING).
MODE = Record(159, "MODE", "QNBB", "TimeUS,Mode,ModeNum,Rsn", "s---", "F---")
MSG = Record(160, "MSG", "QZ", "TimeUS,Message", "s-", "F-")
EV = Record(161, "EV", "QB", "TimeUS,Id", "s-", "F-")
ERR = Record(162, "ERR", "QBB", "TimeUS,Subsys,ECode", "s--", "F--")
PARM = Record(163, "PARM", "QNff", "TimeUS,Name,Value,Default", "s---", "F---")
RECORDS = (ATT, IMU, MAG, BARO, RCOU, WING, EST, PM, FIX, MODE, MSG, EV, ERR, PARM)

#: LOG_BITMASK bits
B_ATT = const(1)
B_IMU = const(2)
B_MAG = const(4)
B_BARO = const(8)
B_SERVO = const(16)
B_EST = const(32)
B_PM = const(64)
B_FIX = const(128)

#: MODE's name field by state number (modes.NAMES), made once: a record packs these
_MODE_NAMES = tuple(n.encode() for n in modes_mod.NAMES)
_NO_MODE = b"MODE?"

#: EV ids (ArduPilot's LogEvent numbers)
EV_ARMED = const(10)
EV_DISARMED = const(11)
EV_LAND_COMPLETE = const(18)   # came to rest
EV_NOT_LANDED = const(28)      # moving again

#: ERR: ``Subsys`` is 100 + the failsafe's bit (firmware/failsafe.py), ``ECode`` 1 raised, 0 cleared.
ERR_FAILSAFE_BASE = const(100)

_RING_MIN_KB = const(4)      # the smallest ring worth logging into
CHUNK = const(4096)            # bytes a flush writes at most: one littlefs block
FLUSH_EVERY = const(10)        # calls between flushes (0.2 s at 50 Hz: 20 kB/s)
STILL_MPS = 0.05
REST_DEPTH_M = 0.5             # armed and still deeper than this: on the bottom
_NOT_STILL = -0.05             # -STILL_MPS, made once (a negation boxes a float each time)
STILL_S = 3
#: The stillness test reads the estimator's speeds through a first-order
#: low-pass of STILL_TAU_S (alpha = 0.02 s / tau): resting on the bottom,
#: the depth sensor's noise (+-20 Pa, 2 mm) put single samples of the
#: vertical speed past STILL_MPS every few seconds, and each one restarted
#: the 3 s of stillness and stopped the flush (the emulated RP2350 after
#: target-landing: landed, moving, landed, ... every 3-5 s, its log never
#: reaching flash). A speed past MOVING_MPS on the raw estimate (twice
#: the noise's worst) ends stillness at once: a release or a lift is not
#: taken for rest while the filter catches up.
STILL_TAU_S = 0.25
_STILL_ALPHA = 0.08            # 0.02 s / STILL_TAU_S
MOVING_MPS = 0.1
_NOT_MOVING = -0.1             # -MOVING_MPS, made once
_CALL_HZ = const(50)
_STILL_CALLS = const(150)      # STILL_S at 50 Hz
_THIN_FRACTION = const(4)      # thin out below a quarter free
#: The stall a chunk's write costs at most, announced first (ms): a sector
#: erase (45 ms), 16 page programs (6.4 ms), a close's metadata commit
#: and, now and then, a metadata compaction (another erase).
CHUNK_STALL_MS = const(110)
#: Header and parameter records a call packs while a log starts.
HEADER_PER_CALL = const(6)
#: A new log's creation: header and parameters (~6 kB: two sectors), two
#: files created (the log, LASTLOG.TXT), old logs maybe removed.
CREATE_STALL_MS = const(300)
#: The kept state behind the ring (``FlightLog._save``): two copies.
_CTL_BYTES = const(64)
_CTL_PACK = "<12I"
_K_MAGIC = const(0x0E4C4F47)    # below 2**30: a small integer on the board
_K_WHOLE = const(1)             # the log's header is whole
_K_LOGGING = const(2)           # armed and logging
_K_CREATE = const(4)            # its file is still to be made (first flush)

_DEG100 = 5729.5779513082    # rad -> centidegrees


class FlightLog:
    """The on-board log.

    Parameters
    ----------
    params:
        The parameter table (LOG_* parameters, and every parameter for PARM).
    telemetry:
        ``shared/mavlink/telemetry.Telemetry``: the values logged, kept
        current by ``refresh(stream)`` (``firmware/telemetry.Reporter``) just
        before they are read.
    files:
        ``files.LogFiles``.
    ticks_us:
        The board's microsecond clock (``time.ticks_us``).
    expect_delay:
        ``expect_delay_ms(ms)`` of the scheduler: called before a flash write.
    """

    def __init__(self, params, telemetry, files, ticks_us, ticks_diff, refresh=None, expect_delay=None,
                 sched=None, fixes=None, ram=None, watchdog_reset=False):
        self.params = params
        self.t = telemetry
        self.files = files
        self._ticks_us = ticks_us
        self._ticks_diff = ticks_diff
        self.refresh = refresh
        self.expect_delay = expect_delay
        self.sched = sched
        self.fixes = fixes            # the endpoint: fix, fix_count, fix_time_us
        self._i_mask = params.index("LOG_BITMASK")
        self._i_disarmed = params.index("LOG_DISARMED")
        kb = params.get_int(params.index("LOG_FILE_BUFSIZE"))
        #: the RAM a watchdog reset keeps (``boards/pico2.py log_ram``), None: the heap's
        self.ram = ram
        #: bytes of the ring LOG_FILE_BUFSIZE asked for and the kept RAM had no room for
        self.ram_short = 0
        #: kB of ring the heap gave: LOG_FILE_BUFSIZE, or half of it again
        #: and again when no block that large is free (a fragmented heap)
        self.ring_kb = kb
        if ram is not None:
            room = len(ram) - 2 * _CTL_BYTES
            size = kb * 1024
            if size > room:
                self.ram_short = size - room
                size = room
            self._ctl = room
            self.w = df.Writer(size, ram)
            kb = size // 1024
        else:
            while True:
                try:
                    self.w = df.Writer(kb * 1024)
                    break
                except MemoryError:
                    if kb <= _RING_MIN_KB:
                        raise
                    kb //= 2
        self.ring_kb = kb
        self.clock = df.Clock()
        self._last_us = ticks_us()
        self._euler = array("f", [0.0, 0.0, 0.0])
        self._v_still = array("f", [0.0, 0.0, 0.0])   # the speeds the stillness test reads (STILL_TAU_S)
        self._n = 0
        self._mode = -1
        self._still = 0
        self._resting = False
        self.armed = False
        self.logging = False
        self._flush_wait = 0
        self._create = False          # the log's file is still to be created (first flush)
        self._hdr = -1                # the next header step of a log starting, -1: none
        self._parm = -1               # the next PARM of a prepared log's parameters again, -1: none
        self._prep = False            # the log is the next dive's, prepared on deck
        self._prep_version = -1
        self._hdr_bytes = 0
        self._hdr_end = 0
        self._reason = ""
        self._fix_seen = 0 if fixes is None else fixes.fix_count
        self._fs_flags = 0
        self._told_dropped = 0
        self._overruns = 0
        self._slots = 0
        self.chunks = 0               # chunks written to flash
        self._seq = 0                 # the kept state's sequence number
        #: bytes of a dive's log found in the kept RAM after a watchdog reset (0: none)
        self.kept_bytes = 0
        self._kept = 0                # the log number the kept ring continues, until armed
        self._hold = False            # the kept ring waits for the vehicle to rest
        if ram is not None:
            if not (watchdog_reset and self._recover()):
                # a power-on (RAM as the supply left it), or nothing whole to keep
                struct.pack_into(_CTL_PACK, ram, self._ctl, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0)
                struct.pack_into(_CTL_PACK, ram, self._ctl + _CTL_BYTES, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0)
            self._save()

    def describe(self):
        """One line for the console at start: where the ring lives and what
        a reset mid-dive loses."""
        if self.ram is None:
            return ("log: a %d kB ring in the heap (no RAM kept across a reset on this build): "
                    "a reset in flight loses the dive's log since arming" % self.ring_kb)
        text = "log: a %d kB ring in RAM a watchdog reset keeps" % self.ring_kb
        if self.ram_short:
            text += " (LOG_FILE_BUFSIZE asks %d kB more than the build keeps)" % ((self.ram_short + 1023) // 1024)
        if self.kept_bytes:
            text += "; %d bytes of the dive's log kept over the reset" % self.kept_bytes
        return text

    # ------------------------------------------------------------ kept RAM
    # Behind the ring, two copies of its state (``_CTL_BYTES`` each, written
    # in turn, so a reset in the middle of a write leaves the other whole):
    # magic, log number, head, tail, wrap, dropped, the clock's two parts,
    # flags, the ring's size, a sequence number and a check of them all.
    # Small integers only: this runs every call in flight.
    def _save(self):
        w = self.w
        seq = (self._seq + 1) & 0xFFFF
        self._seq = seq
        flags = 0
        if self._hdr < 0:
            flags = _K_WHOLE
            if self.logging:
                flags |= _K_LOGGING
            if self._create:
                flags |= _K_CREATE
        number = self.files.current
        c = self.clock
        lo = c.lo
        hi = c.hi & 0xFFFF
        dropped = w.dropped & 0xFFFFF
        wrap = w.wrap + 1
        check = (_K_MAGIC + number * 3 + w.head * 5 + w.tail * 7 + wrap * 11 + dropped * 13 + lo * 17
                 + hi * 19 + flags * 23 + w.size * 29 + seq * 31) & 0x3FFFFFFF
        struct.pack_into(_CTL_PACK, self.ram, self._ctl + (seq & 1) * _CTL_BYTES, _K_MAGIC, number, w.head, w.tail,
                         wrap, dropped, lo, hi, flags, w.size, seq, check)

    def _read_kept(self, slot):
        """The state in copy ``slot``, or None when its check fails."""
        v = struct.unpack_from(_CTL_PACK, self.ram, self._ctl + slot * _CTL_BYTES)
        magic, number, head, tail, wrap, dropped, lo, hi, flags, size, seq, check = v
        if magic != _K_MAGIC:
            return None
        if check != (magic + number * 3 + head * 5 + tail * 7 + wrap * 11 + dropped * 13 + lo * 17
                     + hi * 19 + flags * 23 + size * 29 + seq * 31) & 0x3FFFFFFF:
            return None
        return v

    def _recover(self):
        """After a watchdog reset: the dive's log the ring still holds goes
        on (the same log number), its records to flash once the vehicle
        rests. Nothing when the state fails its check (a power cut: the RAM
        lost it) or the ring is another size; True when the ring was taken."""
        a = self._read_kept(0)
        b = self._read_kept(1)
        if a is None or (b is not None and (b[10] - a[10]) & 0xFFFF < 0x8000):
            a = b
        if a is None:
            return False
        magic, number, head, tail, wrap, dropped, lo, hi, flags, size, seq, check = a
        w = self.w
        if size != w.size or not flags & _K_WHOLE or not (number or flags & _K_CREATE):
            return False
        if not 0 <= tail <= size or not 0 <= head <= size or not 0 <= wrap <= size:
            return False
        w.head = head
        w.tail = tail
        w.wrap = wrap - 1
        w.dropped = dropped
        self._told_dropped = dropped
        self._seq = seq
        self.clock.lo = lo
        self.clock.hi = hi
        self.files.current = number
        self._create = bool(flags & _K_CREATE)
        self.kept_bytes = w.pending()
        if flags & _K_LOGGING:
            self._kept = number or -1      # (-1: its file is still to be made)
            self._hold = True
        return True

    # ------------------------------------------------------------ time
    def _now(self):
        now = self._ticks_us()
        self.clock.advance(self._ticks_diff(now, self._last_us))
        self._last_us = now
        self.w.stamp(self.clock)

    # ------------------------------------------------------------ start
    def start(self, reason_text, prepare=False):
        """A new log: its header and parameters go into the ring over the
        next calls (``HEADER_PER_CALL`` records a call: packing ~130 at
        once took ~25 ms of a slot on a Pico 2); its file is created by the
        first flush after that. ``prepare``: the next dive's log, made on
        deck while disarmed (``step``), so that arming writes nothing."""
        w = self.w
        if self.files.current and w.pending():
            self._drain()           # the last log's tail first: it is still
        w.clear()
        self._kept = 0
        self._hold = False
        self._reason = reason_text
        self._hdr = 0
        self._hdr_end = w.header_items(RECORDS) + self.params.count()
        self._prep = prepare
        self._prep_version = self.params.version
        self.logging = not prepare

    def _arm(self):
        """Armed: the prepared log goes on (parameters changed since it was
        made are recorded again), or a new one starts."""
        self._still = 0             # still again for STILL_S before anything goes to flash
        self._resting = False       # (and no "moving" event for the lift from the deck)
        if self._kept:
            # armed again after a watchdog reset (firmware/resume.py): the
            # dive's log goes on where the reset left it
            self._kept = 0
            self.logging = True
            self.msg(b"watchdog reset: log continues")
            if self._mode >= 0:
                self.mode(self._mode)
            self.event(EV_ARMED)
            return
        if self._prep:
            self._prep = False
            self.logging = True
            if self._hdr >= 0:
                return              # its header is still being packed: EV ARMED follows it
            if self.params.version != self._prep_version:
                self._parm = 0      # every parameter again, a few a call
            self.msg(b"armed")         # (bytes: a str is encoded, an allocation, at each arming)
            if self._mode >= 0:
                self.mode(self._mode)
            self.event(EV_ARMED)
        else:
            self.start("armed: log started")     # EV ARMED once its header is in

    def _header_steps(self):
        w = self.w
        self._now()
        k = self._hdr
        end = self._hdr_end
        n_fmt = end - self.params.count()
        stop = k + HEADER_PER_CALL
        if stop > end:
            stop = end
        p = self.params
        while k < stop:
            if k < n_fmt:
                w.header_item(k, RECORDS)
            else:
                i = k - n_fmt
                o = w.reserve(PARM.length)
                if o >= 0:
                    struct.pack_into(PARM.pack, w.buf, o, HEAD1, HEAD2, PARM.type_id, w.t0, w.t1, w.t2, w.t3,
                                     p.name_bytes(i), p.get(i), p.default(i))
            k += 1
        if k < end:
            self._hdr = k
            return
        # the header is whole: records may follow, and the file be made
        self._hdr = -1
        self._hdr_bytes = w.pending()
        self._create = True
        self._flush_wait = 0
        if self._prep:
            return              # a prepared log: its first records come at arming
        self.msg(self._reason)
        if self._mode >= 0:
            self.mode(self._mode)     # the mode the log starts in
        if self.armed:
            self.event(EV_ARMED)

    def _parm_steps(self):
        w = self.w
        p = self.params
        self._now()
        i = self._parm
        end = p.count()
        stop = i + HEADER_PER_CALL
        if stop > end:
            stop = end
        while i < stop:
            o = w.reserve(PARM.length)
            if o >= 0:
                struct.pack_into(PARM.pack, w.buf, o, HEAD1, HEAD2, PARM.type_id, w.t0, w.t1, w.t2, w.t3,
                                 p.name_bytes(i), p.get(i), p.default(i))
            i += 1
        self._parm = i if i < end else -1

    def _drain(self):
        """Everything waiting to flash now (at arming: the previous log's end)."""
        w = self.w
        while w.pending() and self.files.current:
            self._flush_wait = 0
            before = w.pending()
            self._flush(True)
            if w.pending() >= before:
                break           # the flash refused it: counted in write_errors
        self.files.current = 0

    def stop(self):
        """Disarmed: what is left goes to flash in the next calls; then the log is closed."""
        self.logging = False

    # ------------------------------------------------------------ events
    def msg(self, text):
        if self._hdr >= 0:
            return              # (before the header is whole: DFReader would not know MSG)
        w = self.w
        o = w.reserve(MSG.length)
        if o >= 0:
            self._now()
            struct.pack_into(MSG.pack, w.buf, o, HEAD1, HEAD2, MSG.type_id, w.t0, w.t1, w.t2, w.t3,
                             text if isinstance(text, bytes) else text.encode())

    def mode(self, number, reason=0):
        if not self.logging or self._hdr >= 0:
            return
        w = self.w
        o = w.reserve(MODE.length)
        if o >= 0:
            self._now()
            state = modes_mod.from_custom(number)
            struct.pack_into(MODE.pack, w.buf, o, HEAD1, HEAD2, MODE.type_id, w.t0, w.t1, w.t2, w.t3,
                             _MODE_NAMES[state] if state >= 0 else _NO_MODE, number, reason)

    def event(self, ev):
        if not self.logging or self._hdr >= 0:
            return
        w = self.w
        o = w.reserve(EV.length)
        if o >= 0:
            self._now()
            struct.pack_into(EV.pack, w.buf, o, HEAD1, HEAD2, EV.type_id, w.t0, w.t1, w.t2, w.t3, ev)

    def _err(self, subsys, code):
        w = self.w
        o = w.reserve(ERR.length)
        if o >= 0:
            struct.pack_into(ERR.pack, w.buf, o, HEAD1, HEAD2, ERR.type_id, w.t0, w.t1, w.t2, w.t3,
                             subsys, code)

    # ------------------------------------------------------------ the task
    def prepared(self):
        """The number of the log prepared for the next dive (0: none): not a
        dive's log yet, so a log list leaves it out."""
        return self.files.current if self._prep else 0

    def resting(self):
        """True when flash may be written without costing a dive: disarmed,
        or armed and still on the bottom (the same rule as the log's own
        flushes; the parameter store waits on it too)."""
        return not self.armed or self._resting

    def unflushed(self, number):
        """Bytes of log ``number`` still to reach flash: the ring's while it
        is the dive's log being written, and the MSG that will tell of
        dropped records. A log list right after a disarm then gives the size
        the log will have, which its download reaches, not the part flushed
        so far (the download then went past the listed size)."""
        if number == 0 or number != self.files.current or self._prep:
            return 0
        w = self.w
        return w.pending() + (MSG.length if w.dropped != self._told_dropped else 0)

    def erased(self):
        """The logs were erased (LOG_ERASE, disarmed): nothing waits for a file any more."""
        self.w.clear()
        self._kept = 0
        self._hold = False
        self._hdr = -1
        self._parm = -1
        self._prep = False
        self.files.current = 0
        self._create = False
        self.logging = False

    def step(self, armed, mode=-1):
        """The log task (50 Hz): arming and disarming, mode changes, the
        periodic records, failsafe changes, fixes, and a flush when the
        vehicle is still."""
        if mode != self._mode:
            self._mode = mode
            self.mode(mode)
        if armed != self.armed:
            self.armed = armed
            if armed:
                self._arm()
            else:
                self.event(EV_DISARMED)
                if not self.params.get_int(self._i_disarmed):
                    self.stop()
        elif not self.logging and not self.files.current and not self._prep and not self._create:
            if self.params.get_int(self._i_disarmed):
                self.start("logging while disarmed")
            elif self._still >= _STILL_CALLS:
                self.start("prepared on deck", prepare=True)
        n = self._n + 1
        if n >= _CALL_HZ:
            n = 0
        self._n = n
        t = self.t
        # still: every speed under STILL_MPS for STILL_S
        v = t.vel_ned
        lp = self._v_still
        lp[0] += _STILL_ALPHA * (v[0] - lp[0])
        lp[1] += _STILL_ALPHA * (v[1] - lp[1])
        lp[2] += _STILL_ALPHA * (v[2] - lp[2])
        if (_NOT_STILL < lp[0] < STILL_MPS and _NOT_STILL < lp[1] < STILL_MPS and _NOT_STILL < lp[2] < STILL_MPS
                and _NOT_MOVING < v[0] < MOVING_MPS and _NOT_MOVING < v[1] < MOVING_MPS
                and _NOT_MOVING < v[2] < MOVING_MPS):
            if self._still < _STILL_CALLS:
                self._still += 1
        else:
            self._still = 0
            if lp[0] != lp[0] or lp[1] != lp[1] or lp[2] != lp[2]:
                lp[0] = lp[1] = lp[2] = 0.0   # a NaN would hold the filter for ever: start again
        # armed, only resting on the bottom is harmless: still at the
        # surface, the vehicle may be let go any moment
        resting = self._still >= _STILL_CALLS and (not armed or t.env[0] >= REST_DEPTH_M)
        if self._hdr >= 0:
            self._header_steps()
        elif self._parm >= 0:
            self._parm_steps()
        elif self.logging:
            self._records(n)
            if resting != self._resting:
                self.event(EV_LAND_COMPLETE if resting else EV_NOT_LANDED)
        self._resting = resting
        harmless = resting or not armed
        if self._hold:
            # a ring kept over a reset in the water: still for STILL_S first
            # (at rest on the bottom, or disarmed and still), as a log
            # started by a reset in the water waits
            if self._still >= _STILL_CALLS:
                self._hold = False
            else:
                harmless = False
        self._flush(harmless)
        if self.ram is not None:
            self._save()

    def _records(self, n):
        """The periodic records of call ``n`` (0-49), spread so that no call
        packs more than two: ATT on even calls and IMU on odd ones (25 Hz
        each), the 10 Hz records each on its own fifth of the calls."""
        t = self.t
        w = self.w
        mask = self.params.get_int(self._i_mask)
        thin = w.free() * _THIN_FRACTION < w.size
        refresh = self.refresh
        self._now()
        if not thin or n % 10 < 2 or n & 1 == 0:      # thinned: IMU at 5 Hz, ATT kept
            if n & 1 == 0:
                if mask & B_ATT:
                    if refresh is not None:
                        refresh(0)      # attitude and rates
                    e = self._euler
                    quat.to_euler(e, t.q)
                    yaw = e[2] * _DEG100
                    if yaw < 0.0:
                        yaw += 36000.0
                    o = w.reserve(ATT.length)
                    if o >= 0:
                        struct.pack_into(ATT.pack, w.buf, o, HEAD1, HEAD2, ATT.type_id, w.t0, w.t1, w.t2, w.t3,
                                         int(e[0] * _DEG100), int(e[1] * _DEG100), int(yaw))
            elif mask & B_IMU:
                if refresh is not None:
                    refresh(2)          # the IMU in body axes
                m = t.imu
                o = w.reserve(IMU.length)
                if o >= 0:
                    struct.pack_into(IMU.pack, w.buf, o, HEAD1, HEAD2, IMU.type_id, w.t0, w.t1, w.t2, w.t3,
                                     0, m[3], m[4], m[5], m[0], m[1], m[2])
        k = n % 5
        if k == 0:
            if mask & B_MAG and not thin and n % 10 == 0:     # 5 Hz
                if refresh is not None:
                    refresh(2)
                m = t.imu
                o = w.reserve(MAG.length)
                if o >= 0:
                    struct.pack_into(MAG.pack, w.buf, o, HEAD1, HEAD2, MAG.type_id, w.t0, w.t1, w.t2, w.t3,
                                     0, m[6], m[7], m[8])
        elif k == 1:
            if mask & B_BARO:
                if refresh is not None:
                    refresh(1)          # position, and the depth
                    refresh(2)          # pressure and temperature
                env = t.env
                o = w.reserve(BARO.length)
                if o >= 0:
                    struct.pack_into(BARO.pack, w.buf, o, HEAD1, HEAD2, BARO.type_id, w.t0, w.t1, w.t2, w.t3,
                                     0, -env[0], env[1], env[2])
        elif k == 2:
            if mask & B_SERVO and not thin and n % 10 == 2:   # 5 Hz
                if refresh is not None:
                    refresh(3)          # servos
                u = t.servo_us
                o = w.reserve(RCOU.length)
                if o >= 0:
                    struct.pack_into(RCOU.pack, w.buf, o, HEAD1, HEAD2, RCOU.type_id, w.t0, w.t1, w.t2, w.t3,
                                     u[0], u[1], u[2], u[3])
                s = t.servo_deg
                o = w.reserve(WING.length)
                if o >= 0:
                    struct.pack_into(WING.pack, w.buf, o, HEAD1, HEAD2, WING.type_id, w.t0, w.t1, w.t2, w.t3,
                                     int(s[0] * 100.0), int(s[1] * 100.0), int(s[2] * 100.0), int(s[3] * 100.0))
        elif k == 3:
            if mask & B_EST:
                if refresh is not None:
                    refresh(1)
                p = t.pos_ned
                v = t.vel_ned
                g = t.target_ned
                o = w.reserve(EST.length)
                if o >= 0:
                    r = t.var_ned
                    struct.pack_into(EST.pack, w.buf, o, HEAD1, HEAD2, EST.type_id, w.t0, w.t1, w.t2, w.t3,
                                     p[0], p[1], p[2], v[0], v[1], v[2], g[0], g[1], r[0], r[2])
        elif n == 9 and mask & B_PM:     # 1 Hz
            self._pm()
        # failsafes raised and cleared
        flags = t.failsafe_flags
        changed = flags ^ self._fs_flags
        if changed:
            self._fs_flags = flags
            bit = 0
            while changed:
                if changed & 1:
                    self._err(ERR_FAILSAFE_BASE + bit, (flags >> bit) & 1)
                changed >>= 1
                bit += 1
        fx = self.fixes
        if fx is not None and fx.fix_count != self._fix_seen:
            self._fix_seen = fx.fix_count
            if mask & B_FIX:
                f = fx.fix
                age_ms = self._ticks_diff(self._last_us, fx.fix_time_us) // 1000
                o = w.reserve(FIX.length)
                if o >= 0:
                    struct.pack_into(FIX.pack, w.buf, o, HEAD1, HEAD2, FIX.type_id, w.t0, w.t1, w.t2, w.t3,
                                     f[0], f[1], f[2], age_ms if age_ms > 0 else 0)

    def _pm(self):
        w = self.w
        s = self.sched
        overruns = slots = max_us = load = 0
        if s is not None:
            overruns = s.overruns - self._overruns
            self._overruns = s.overruns
            slots = s.cycles - self._slots
            self._slots = s.cycles
            max_us = s.max_loop_us
            load = s.load_permille
        o = w.reserve(PM.length)
        if o >= 0:
            struct.pack_into(PM.pack, w.buf, o, HEAD1, HEAD2, PM.type_id, w.t0, w.t1, w.t2, w.t3,
                             overruns & 0xFFFF, slots & 0xFFFF, max_us, load, w.dropped & 0xFFFF)

    # ------------------------------------------------------------ flash
    def _flush(self, harmless):
        """One chunk to flash when harmless and due (or the log closes)."""
        if self._flush_wait > 0:
            self._flush_wait -= 1
            return
        w = self.w
        if not harmless or not (self.files.current or self._create) or not w.pending():
            if not self.logging and not self._prep and self.files.current and not w.pending():
                self.files.current = 0      # the log is complete on flash
                self._kept = 0              # (a kept log no arming continued: closed)
            return
        if self.expect_delay is not None:
            self.expect_delay(CREATE_STALL_MS if self._create else CHUNK_STALL_MS)
        # w.chunk(CHUNK) written out: its tuple would be garbage at each flush
        o = w.tail
        n = (w.head if w.wrap < 0 else w.wrap) - o
        if n > CHUNK:
            n = CHUNK
        if self._create:
            self._create = False
            try:
                self.files.create(memoryview(w.buf)[o:o + n], w.size, self._hdr_bytes if self._prep else 0)
                ok = True
            except OSError:
                self.files.write_errors += 1
                self.files.current = 0
                ok = False
        else:
            ok = self.files.append(w.buf, o, n)
        if ok:
            w.taken(n)
            if self.ram is not None:
                self._save()        # (on flash now: a reset must not write them twice)
            self.chunks += 1
            if w.dropped != self._told_dropped:     # (said now: there is room again)
                self._now()
                self.msg("log: %d records dropped, the buffer was full" % (w.dropped - self._told_dropped))
                self._told_dropped = w.dropped
        self._flush_wait = FLUSH_EVERY
