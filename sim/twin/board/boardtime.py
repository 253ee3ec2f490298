"""The board's compute time in the twin: counted on the emulated RP2350, or modelled.

MicroPython code, loaded beside the firmware (``lockstep.py`` sets it up).
Without it the virtual clock moves only when the firmware sleeps, so code
is free and no loop can overrun. With it every clock reading first moves
time on by the work the board's CPU did since the last one
(``vclock.set_cpu``), so a task takes as long as it would on the chip, the
sensors and the world move on meanwhile, and overruns, skipped slots and
the watchdog behave as they will on the board.

Two sources of that work, one interface:

- ``"emu"``: the firmware runs on the emulated RP2350
  (``tools/rp2350_emu/``, ``--interpreter rp2350-emu``), whose native
  ``emuboard`` module counts the instructions the CPU executed and turns
  them into microseconds at the calibrated cost per instruction. The
  twin's own Python (the emulated peripherals, the virtual clock, the
  lockstep) runs on the same CPU but is not the board's work: each entry
  into it is bracketed by ``emuboard.exclude_begin/end`` so its
  instructions are not charged. What the chip spends outside its CPU is
  charged explicitly (``charge``): an I2C transfer's bus time, a flash
  write's stall.
- ``"model"``: any other interpreter. A deterministic model calibrated on
  the emulated board (``sim/twin/board_time_model.json``, written by
  ``roboray-sim bench board --write-model``) charges each task call its
  mean cost on the chip in the vehicle's current state (``Modes.state``:
  its mode armed, DISARMED disarmed), each collection
  its cost at the firmware's live heap, and the same flash stalls.

``--cpu-mhz`` scales the compute part (not bus time, not flash stalls).

Every task call, collection and slot is recorded, ``(kind << 24) | (state
<< 21) | us`` (the vehicle's ``Modes.state`` then; us capped at 2**21 - 1),
into a buffer the lockstep sends to the host with its frame request
(``take_records``): kinds 0..15 are the scheduler's tasks in the order
added, ``GC`` a collection, ``SLOT`` a slot's work from its start to the
end of its collection (the scheduler's own ``work``), ``FLASH`` a flash
stall. The host turns them into per-task mean, p99 and max.

The heap is counted too (``gc.mem_alloc()`` around each task call, read
inside the bracket on the emulated board so it is not charged): ``ALLOC``
ends each slot's records (before its ``SLOT``) with the bytes its tasks
allocated, the "gc" task's call left out (its collection frees), and
``AUTO_GC`` marks a task call after which the heap held fewer bytes than
before it: a collection the allocator made when the heap was full, which
nothing else reports. ``roboray-sim bench board`` turns the armed slots'
records into ``flight_alloc_bytes_per_slot`` and ``flight_collections``.
A collection inside a task that freed less than the task allocated is
not seen: on the RoboRay build the firmware's slots leave a few bytes, so
such a collection would find the heap nearly empty of garbage.
"""

import gc
import sys
from array import array

try:
    _mem_alloc = gc.mem_alloc
except AttributeError:  # CPython: no heap to count
    def _mem_alloc():
        return 0

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

from roboray.sim.twin.board import vclock

try:
    import emuboard
except ImportError:
    emuboard = None

GC = const(16)
SLOT = const(17)
FLASH = const(18)
ALLOC = const(19)
AUTO_GC = const(20)
_MASK = const(0x3FFFFFFF)
_US_MAX = const(0x1FFFFF)
_RECORDS = const(512)
#: On the emulated board the twin's own Python (the emulated peripherals,
#: the lockstep's frames: a few kB a 20 ms frame) shares the firmware's
#: heap, which a Pico 2 does not: left there, it filled the heap every few
#: seconds, so the allocator collected inside the firmware's tasks, and its
#: garbage between the firmware's blocks made each of the firmware's heap
#: allocations (its larger call frames) search further: collected every 10
#: slots, bench board's slot p99 / max without flash saves 7.45 / 8.39 ms,
#: every slot 7.00 / 7.63 (nav mean 2682 -> 2599 us). (The emulated
#: board's kept-log dive that flushed only to 28.1 s with it was the
#: logger's stillness flapping at rest, since fixed: firmware/flightlog/
#: logger.py STILL_TAU_S.) So it is collected every TWIN_GC_SLOTS slots,
#: inside the exclusion (not charged), while the
#: firmware's own bytes since its last collection fit what a Pico 2's heap
#: has free (``BoardTime.fw_budget``); past that the board would have
#: collected, and the twin leaves the collection to the firmware's
#: allocator, charged, as on the chip. The firmware's bytes are known only
#: where the heap is counted (``heap``, ``bench board``: ~3 B an armed
#: slot against ~250 kB free); a twin that does not count them collects
#: its garbage every TWIN_GC_SLOTS regardless.
TWIN_GC_SLOTS = const(1)
#: What the twin keeps live on the emulated board's heap, at most (the
#: emulated heap is the Pico 2's plus this: ``rp2350_emu.TWIN_HEAP``).
TWIN_HEAP = 128 * 1024
#: The clock the model and the calibration refer to (RP2350 default).
REF_MHZ = 150

# Flash stalls. Writing or erasing the Pico 2's QSPI flash (Winbond
# W25Q32RV class) suspends execution from flash for the whole operation;
# MicroPython's littlefs on rp2 writes 4 kB blocks. Typical figures of the
# W25Q32JV datasheet (rev. H, table 9.7): page program (256 B) 0.4 ms,
# 4 kB sector erase 45 ms.
PAGE_PROGRAM_US = 400
SECTOR_ERASE_US = 45000
PAGE_BYTES = 256
SECTOR_BYTES = 4096
#: littlefs appends a commit to a metadata pair and erases (compacts) the
#: pair's other block when it fills: about every 16 commits of ~250 bytes.
COMMITS_PER_ERASE = 16

# I2C on the RP2350: the pico-sdk's blocking transfers spin until the bus is
# done, so a transfer costs its bus time (9 bits a byte with the ACK, start
# and stop) plus the driver's set-up, estimated at 5 us (a few hundred
# instructions of machine_i2c and the SDK at 150 MHz).
I2C_SETUP_US = 5


class BoardTime:
    """The board's compute clock and the recorder; see the module docstring.

    ``source``: ``"emu"`` or ``"model"``; ``model``: the calibrated table
    (dict) for ``"model"``; ``cpu_mhz``: the board's clock; ``ps_per_insn``:
    the emulated board's calibrated cost of an instruction at ``REF_MHZ``;
    ``heap``: count each task call's heap bytes (``ALLOC``, ``AUTO_GC``).
    A count is ``gc.mem_alloc()``, which walks the whole heap: ~80 us on
    the host build's 608 kB, twice a task call, two thirds of the default
    twin's board time; on the emulated board it is not charged.
    """

    def __init__(self, source, model=None, cpu_mhz=REF_MHZ, ps_per_insn=None, heap=True):
        if source not in ("emu", "model"):
            raise ValueError("board time source %r: emu or model" % (source,))
        if source == "emu" and emuboard is None:
            raise ValueError("board time 'emu' needs the emulated RP2350 (no emuboard module here)")
        if source == "model" and model is None:
            raise ValueError("board time 'model' needs the calibrated model")
        if not cpu_mhz > 0:
            raise ValueError("cpu_mhz must be > 0, got %r" % (cpu_mhz,))
        self.source = source
        self.cpu_mhz = cpu_mhz
        self.heap = heap
        self.records = array("i", [0] * _RECORDS)
        self.n = 0
        self.lost = 0
        self.names = []
        self.busy = 0           # model: us of work so far, wrapping at 2**30
        self.commits = 0
        self.flash_us = 0
        self._modes = None
        #: bytes the current slot's tasks allocated so far
        self.alloc = array("i", [0])
        #: bytes the emulated peripherals allocated in the current task
        #: call, and how deep in their brackets it is (``bracket_emulation``)
        self.emu_alloc = array("i", [0, 0])
        self._gc_task = -1
        #: the firmware's bytes since its last collection, and what a Pico
        #: 2's heap has free for them (set as the loop starts; -1: unknown)
        self.fw_since = 0
        self.fw_budget = -1
        #: the twin's collections of its own garbage (TWIN_GC_SLOTS), and
        #: the slots since the last
        self.twin_collections = 0
        self._twin_k = 0
        #: 1 once the firmware's collector.collect() ran in the current task call
        self._collected = array("b", [0])
        if source == "emu":
            ps = ps_per_insn if ps_per_insn else 6667
            self._ps = int(ps * REF_MHZ / cpu_mhz + 0.5)
            emuboard.config(self._ps)
            self.busy_us = emuboard.busy_us
            self.charge = self._charge_emu
        else:
            scale = REF_MHZ / cpu_mhz
            self._task_us = {}
            for name, costs in model["tasks"].items():
                self._task_us[name] = [int(c * scale + 0.5) for c in costs]
            self._gc_us = int(model["gc_us"] * scale + 0.5)
            self._costs = []
            self.busy_us = self._busy_model
            self.charge = self._charge_model

    # ------------------------------------------------------------ the clock
    def _busy_model(self):
        return self.busy

    def _charge_model(self, us):
        self.busy = (self.busy + us) & _MASK

    @staticmethod
    def _charge_emu(us):
        emuboard.charge_us(us)

    def start(self):
        """From now on code takes time (the firmware is about to run)."""
        if self.source == "emu":
            # the board's clock on to a whole microsecond: its readings from
            # here depend only on what runs from here, not on the fraction
            # of a microsecond the start-up left (emuboard.config)
            emuboard.config(self._ps)
        vclock.set_cpu(self.busy_us)

    def stop(self):
        vclock.set_cpu(None)

    # ------------------------------------------------------------ records
    def record(self, kind, us):
        n = self.n
        if n >= _RECORDS:
            self.lost += 1
            return
        m = self._modes if self.source == "model" else _vehicle_modes()
        mode = m.state if m is not None else 0
        self.records[n] = (kind << 24) | (mode << 21) | (us if us < _US_MAX else _US_MAX)
        self.n = n + 1

    def take_records(self):
        """The records since the last call, as bytes (allocates: the twin's side)."""
        n = self.n
        self.n = 0
        return bytes(memoryview(self.records)[:n]) if n else b""

    # ------------------------------------------------------------ the loop
    def instrument(self, sched, modes):
        """Time every task and the collection of ``sched`` (and charge them,
        for the model). Called as the loop starts; ``modes``: the vehicle's
        ``Modes`` (the model's costs depend on its ``state``). On the
        emulated board the records look the vehicle's modes up instead of
        keeping them: a twin object holding the firmware's would tie the two
        into one cycle for the firmware's collector (``firmware/collector.py``)."""
        self._modes = modes if self.source == "model" else None
        self.names = list(sched.names)
        self._gc_task = self.names.index("gc") if "gc" in self.names else -1
        fns = sched._fns
        emu = self.source == "emu"
        if emu and self.heap:
            # the firmware's free heap on a Pico 2, at most: the emulated
            # heap's free less all the twin may keep (the twin keeps less)
            self.fw_budget = gc.mem_free() - TWIN_HEAP
        self.fw_since = 0
        for i in range(len(fns)):
            if emu:
                fns[i] = self._wrap_emu(i, fns[i])
            else:
                costs = self._task_us.get(sched.names[i])
                if costs is None:
                    raise ValueError("the board time model has no task %r: run "
                                     "roboray-sim bench board --write-model" % sched.names[i])
                fns[i] = self._wrap_model(i, fns[i], costs)
        # the slot's end: its collection, or none (the application's "gc" task)
        sched._collect = self._wrap_collect(sched._collect or _nothing, sched, emu,
                                            sched._collect is not None)
        self._wrap_firmware_collect(emu)

    def _wrap_firmware_collect(self, emu):
        """The collections the firmware makes inside a task
        (``collector.collect()``: RoboRay's build collects from its log task,
        at rest or when its heap estimate runs low) timed and recorded as
        ``GC``, as the "gc" task's are (the slot is a planned stall; the
        model charges its collection). The original function is called, so
        the collector's marking order holds (``firmware/collector.py``)."""
        global _collect_orig
        collector = sys.modules.get("roboray.firmware.collector")
        if collector is None:
            return
        if _collect_orig is None:
            _collect_orig = collector.collect
        orig = _collect_orig
        rec = self.record
        bt = self
        done = self._collected
        if emu:
            xb = emuboard.exclude_begin
            xe = emuboard.exclude_end
            busy = emuboard.busy_us

            def collect():
                xb()
                b0 = busy()
                xe()
                orig()
                xb()
                rec(GC, (busy() - b0) & _MASK)
                done[0] = 1
                xe()
        else:
            gc_us = self._gc_us

            def collect():
                orig()
                bt.busy = (bt.busy + gc_us) & _MASK
                rec(GC, gc_us)
                done[0] = 1
        collector.collect = collect

    def _count(self, i, a0):
        """The heap after task ``i``'s call, which found ``a0`` bytes allocated."""
        d = _mem_alloc() - a0 - self.emu_alloc[0]
        c = self._collected
        if i == self._gc_task or c[0]:
            # the firmware collected (its "gc" task, or collector.collect()
            # inside the call: recorded as GC)
            c[0] = 0
            self.fw_since = 0
            if i != self._gc_task and d > 0:
                self.alloc[0] += d
            return
        if d < 0:
            # a collection inside the call the firmware did not ask for:
            # the allocator's, on a full heap
            self.record(AUTO_GC, 0)
            self.fw_since = 0
        else:
            self.alloc[0] += d

    def _wrap_emu(self, i, fn):
        xb = emuboard.exclude_begin
        xe = emuboard.exclude_end
        busy = emuboard.busy_us
        rec = self.record
        if not self.heap:
            def run():
                xb()
                b0 = busy()
                xe()
                try:
                    fn()
                finally:
                    xb()
                    rec(i, (busy() - b0) & _MASK)
                    xe()
            return run
        count = self._count
        mem_alloc = _mem_alloc

        ea = self.emu_alloc

        def run():
            xb()
            b0 = busy()
            ea[0] = 0
            a0 = mem_alloc()
            xe()
            try:
                fn()
            finally:
                xb()
                count(i, a0)
                rec(i, (busy() - b0) & _MASK)
                xe()
        return run

    def _wrap_model(self, i, fn, costs):
        rec = self.record
        bt = self
        if not self.heap:
            def run():
                f0 = bt.flash_us
                try:
                    fn()
                finally:
                    c = costs[bt._modes.state]
                    bt.busy = (bt.busy + c) & _MASK
                    rec(i, c + bt.flash_us - f0)
            return run
        count = self._count
        mem_alloc = _mem_alloc

        def run():
            f0 = bt.flash_us
            a0 = mem_alloc()
            try:
                fn()
            finally:
                count(i, a0)
                c = costs[bt._modes.state]
                bt.busy = (bt.busy + c) & _MASK
                # the call's time as the board's: its cost and its flash stalls
                rec(i, c + bt.flash_us - f0)
        return run

    def _end_slot(self):
        if self.source == "emu":
            self._twin_collect()
        if not self.heap:
            return
        a = self.alloc
        self.record(ALLOC, a[0])
        self.fw_since += a[0]
        a[0] = 0

    def _twin_collect(self):
        """The twin's garbage off the emulated heap (inside the exclusion;
        see TWIN_GC_SLOTS), while the firmware's own fits a Pico 2's."""
        k = self._twin_k + 1
        if k < TWIN_GC_SLOTS:
            self._twin_k = k
            return
        self._twin_k = 0
        if self.fw_budget >= 0 and self.fw_since >= self.fw_budget:
            return
        gc.collect()
        self.twin_collections += 1

    def _wrap_collect(self, collect, sched, emu, collects):
        rec = self.record
        bt = self
        end = self._end_slot
        if not collects:
            if emu:
                xb = emuboard.exclude_begin
                xe = emuboard.exclude_end

                def run():
                    rec(SLOT, (vclock.ticks_us() - sched.now_us) & _MASK)
                    xb()
                    end()
                    xe()
            else:
                def run():
                    rec(SLOT, (vclock.ticks_us() - sched.now_us) & _MASK)
                    end()
            return run
        if emu:
            xb = emuboard.exclude_begin
            xe = emuboard.exclude_end
            busy = emuboard.busy_us

            def run():
                xb()
                b0 = busy()
                xe()
                collect()
                xb()
                try:
                    end()
                    rec(GC, (busy() - b0) & _MASK)
                    # the clock reading may end the life (the watchdog bites)
                    rec(SLOT, (vclock.ticks_us() - sched.now_us) & _MASK)
                finally:
                    xe()
        else:
            gc_us = self._gc_us

            def run():
                collect()
                end()
                bt.busy = (bt.busy + gc_us) & _MASK
                rec(GC, gc_us)
                rec(SLOT, (vclock.ticks_us() - sched.now_us) & _MASK)
        return run

    # ------------------------------------------------------------ flash
    def flash(self, kind, nbytes=0):
        """Charge the stall of one flash-changing file operation:
        ``"open"``, ``"write"`` (``nbytes``), ``"close"``, ``"rename"``,
        ``"remove"`` (littlefs: a write programs pages and erases the
        sectors it starts; the others commit metadata)."""
        if kind == "write":
            us = ((nbytes + PAGE_BYTES - 1) // PAGE_BYTES) * PAGE_PROGRAM_US
            us += ((nbytes + SECTOR_BYTES - 1) // SECTOR_BYTES) * SECTOR_ERASE_US
        else:
            us = PAGE_PROGRAM_US
            self.commits += 1
            if self.commits % COMMITS_PER_ERASE == 0:
                us += SECTOR_ERASE_US
        self.flash_us += us
        self.record(FLASH, us)
        self.charge(us)

    # ------------------------------------------------------------ I2C
    @staticmethod
    def i2c_us(freq, nbytes):
        """Bus time of a transfer of ``nbytes`` (address bytes included) at ``freq`` Hz."""
        return I2C_SETUP_US + ((nbytes * 9 + 2) * 1000000 + freq - 1) // freq


def _nothing():
    pass


# collector.collect as the firmware defined it (BoardTime._wrap_firmware_collect)
_collect_orig = None


def _no_heap():
    return 0


def _vehicle_modes():
    app = sys.modules.get("roboray.firmware.app")
    v = app.vehicle if app is not None else None
    return v.modes if v is not None else None


# The heap counted inside the emulation's brackets (``bracket_emulation``):
# set there, read by the inner calls below.
_ea = array("i", [0, 0])
_ma = _mem_alloc


# The inner calls: the heap read around the emulated peripheral's own call,
# inside the bracket. A bracket's wrapper keeps no more locals than its
# arguments and what it closes over (the function, the bracket's two
# natives): MicroPython gives a call whose locals and stack need more than
# 11 words a frame on the heap (``VM_MAX_STATE_ON_STACK``, py/objfun.c),
# and a wrapper that did (the heap reads in the wrapper itself, commit
# c31bba8) allocated one before its bracket opened and freed it after it
# closed, both charged to the firmware: 500-700 instructions a call, and on
# a heap the twin's garbage fragments a search of the allocation table from
# the lowest freed block, 80,000 (counted on the emulated board: bracketed
# calls in a loop, old wrapper against new). These frames are allocated and
# freed inside the bracket.
def _in0(f):
    ea = _ea
    n = ea[1]
    ea[1] = n + 1
    a0 = _ma()
    try:
        return f()
    finally:
        ea[1] = n
        if n == 0:
            ea[0] += _ma() - a0


def _in1(f, a):
    ea = _ea
    n = ea[1]
    ea[1] = n + 1
    a0 = _ma()
    try:
        return f(a)
    finally:
        ea[1] = n
        if n == 0:
            ea[0] += _ma() - a0


def _in2(f, a, b):
    ea = _ea
    n = ea[1]
    ea[1] = n + 1
    a0 = _ma()
    try:
        return f(a, b)
    finally:
        ea[1] = n
        if n == 0:
            ea[0] += _ma() - a0


def _in3(f, a, b, c):
    ea = _ea
    n = ea[1]
    ea[1] = n + 1
    a0 = _ma()
    try:
        return f(a, b, c)
    finally:
        ea[1] = n
        if n == 0:
            ea[0] += _ma() - a0


def _in4(f, a, b, c, d):
    ea = _ea
    n = ea[1]
    ea[1] = n + 1
    a0 = _ma()
    try:
        return f(a, b, c, d)
    finally:
        ea[1] = n
        if n == 0:
            ea[0] += _ma() - a0


def _in5(f, a, b, c, d, e):
    ea = _ea
    n = ea[1]
    ea[1] = n + 1
    a0 = _ma()
    try:
        return f(a, b, c, d, e)
    finally:
        ea[1] = n
        if n == 0:
            ea[0] += _ma() - a0


def _in_any(f, a, kw):
    ea = _ea
    n = ea[1]
    ea[1] = n + 1
    a0 = _ma()
    try:
        return f(*a, **kw)
    finally:
        ea[1] = n
        if n == 0:
            ea[0] += _ma() - a0


# The hot calls with many arguments (the IMU's FIFO burst, the radio's
# reads and writes): module functions, so their wrappers hold nothing but
# their arguments and fit a frame on the C stack (see _in0); the bracket
# opens in the wrapper and the inner call closes it. Set by
# bracket_emulation.
_xb = None
_xe = None
_charge = None
_i2c_us = None
_orig = {}


def _rmi(self, addr, memaddr, buf, addrsize):
    try:
        _charge(_i2c_us(self.freq, 3 + len(buf)))
        _in5(_orig["readfrom_mem_into"], self, addr, memaddr, buf, addrsize)
    finally:
        _xe()


def _w_readfrom_mem_into(self, addr, memaddr, buf, addrsize=8):
    _xb()
    return _rmi(self, addr, memaddr, buf, addrsize)


def _rfi(self, addr, buf, stop):
    try:
        _charge(_i2c_us(self.freq, 1 + len(buf)))
        _in4(_orig["readfrom_into"], self, addr, buf, stop)
    finally:
        _xe()


def _w_readfrom_into(self, addr, buf, stop=True):
    _xb()
    return _rfi(self, addr, buf, stop)


def _wto(self, addr, buf, stop):
    try:
        _charge(_i2c_us(self.freq, 1 + len(buf)))
        return _in4(_orig["writeto"], self, addr, buf, stop)
    finally:
        _xe()


def _w_writeto(self, addr, buf, stop=True):
    _xb()
    return _wto(self, addr, buf, stop)


def _uri(self, buf, n):
    try:
        return _in3(_orig["readinto"], self, buf, n)
    finally:
        _xe()


def _w_uart_readinto(self, buf, n=-1):
    _xb()
    return _uri(self, buf, n)


def _uw(self, buf, off, n):
    try:
        return _in4(_orig["write"], self, buf, off, n)
    finally:
        _xe()


def _w_uart_write(self, buf, off=0, n=-1):
    _xb()
    return _uw(self, buf, off, n)


def bracket_emulation(machine, bt):
    """On the emulated RP2350: the twin's ``machine`` and clock are the
    board's peripherals and timer, not its firmware: exclude their Python
    from the charged instructions, and charge the bus time of I2C transfers.

    The wrappers take the wrapped function's own arguments, not ``*args``
    and ``**kwargs``: those build a tuple and a dict at every call, before
    the bracket opens, so the call would be charged for the twin's garbage
    (and the first allocation after a collection searches the heap).

    Inside each bracket the heap is read too (the inner calls above): what
    the emulated peripherals allocate (``bt.emu_alloc[0]``, the outermost
    bracket's only: they nest) is the twin's garbage, not the firmware's,
    and is left out of the task's bytes (``BoardTime._count``); not when the
    heap is not counted (``BoardTime.heap``: each reading walks the heap)."""
    global _ea, _ma, _xb, _xe, _charge, _i2c_us
    xb = emuboard.exclude_begin
    xe = emuboard.exclude_end
    _xb = xb
    _xe = xe
    _charge = emuboard.charge_us
    _i2c_us = bt.i2c_us
    _ea = bt.emu_alloc
    _ma = _mem_alloc if bt.heap else _no_heap

    def any_args(f):   # set-up calls (constructors' init): rare
        def call(*a, **kw):
            xb()
            try:
                return _in_any(f, a, kw)
            finally:
                xe()
        return call

    def f0(f):
        def call():
            xb()
            try:
                return _in0(f)
            finally:
                xe()
        return call

    def f1(f, default):
        def call(a=default):
            xb()
            try:
                return _in1(f, a)
            finally:
                xe()
        return call

    def m0(f):
        def call(self):
            xb()
            try:
                return _in1(f, self)
            finally:
                xe()
        return call

    def m1(f, default):
        def call(self, a=default):
            xb()
            try:
                return _in2(f, self, a)
            finally:
                xe()
        return call

    def m2(f, default):
        def call(self, a, b=default):
            xb()
            try:
                return _in3(f, self, a, b)
            finally:
                xe()
        return call

    def m3(f, d1, d2):
        def call(self, a, b=d1, c=d2):
            xb()
            try:
                return _in4(f, self, a, b, c)
            finally:
                xe()
        return call

    for name in ("ticks_us", "ticks_ms", "ticks_cpu", "time", "time_ns", "catch_up"):
        setattr(vclock, name, f0(getattr(vclock, name)))
    # the sleeps (once a slot) keep the generic wrapper: with a one-argument
    # wrapper the loop's figures came out 50 % higher and nothing here says
    # why (measured both ways on target-landing; the ticks are read 30 times
    # a slot and take the cheap wrapper)
    for name in ("sleep_us", "sleep_ms", "sleep", "advance"):
        setattr(vclock, name, any_args(getattr(vclock, name)))
    Pin, PWM, UART = machine.Pin, machine.PWM, machine.UART
    Pin.init = any_args(Pin.init)
    Pin.value = m1(Pin.value, None)
    for name in ("on", "off", "high", "low", "toggle"):
        setattr(Pin, name, m0(getattr(Pin, name)))
    PWM.init = any_args(PWM.init)
    for name in ("freq", "duty_u16", "duty_ns"):
        setattr(PWM, name, m1(getattr(PWM, name), None))
    PWM.deinit = m0(PWM.deinit)
    UART.init = any_args(UART.init)
    for name in ("any", "readline", "txdone", "flush"):
        setattr(UART, name, m0(getattr(UART, name)))
    UART.read = m1(UART.read, -1)
    _orig["readinto"] = UART.readinto
    UART.readinto = _w_uart_readinto
    _orig["write"] = UART.write
    UART.write = _w_uart_write
    machine.ADC.read_u16 = m0(machine.ADC.read_u16)
    machine.WDT.feed = m0(machine.WDT.feed)
    machine.I2C.scan = m0(machine.I2C.scan)
    machine.I2C.writevto = any_args(machine.I2C.writevto)
    for name in ("reset_cause", "unique_id", "idle", "disable_irq"):
        setattr(machine, name, f0(getattr(machine, name)))
    machine.freq = f1(machine.freq, None)
    machine.enable_irq = f1(machine.enable_irq, 0)

    charge = emuboard.charge_us
    i2c_us = bt.i2c_us
    I2C = machine.I2C
    read_mem = I2C.readfrom_mem_into
    read_mem_b = I2C.readfrom_mem
    write_mem = I2C.writeto_mem
    read_into = I2C.readfrom_into
    read_b = I2C.readfrom
    write = I2C.writeto

    # addr + register, then addr again and the data (a repeated start).
    # The rarer transfers keep closures, whose frames are on the heap (see
    # _in0); the hot ones are the module's _w_* functions above.
    def readfrom_mem(self, addr, memaddr, nbytes, addrsize=8):
        xb()
        try:
            charge(i2c_us(self.freq, 3 + nbytes))
            return _in5(read_mem_b, self, addr, memaddr, nbytes, addrsize)
        finally:
            xe()

    def writeto_mem(self, addr, memaddr, buf, addrsize=8):
        xb()
        try:
            charge(i2c_us(self.freq, 2 + len(buf)))
            _in5(write_mem, self, addr, memaddr, buf, addrsize)
        finally:
            xe()

    def readfrom(self, addr, nbytes, stop=True):
        xb()
        try:
            charge(i2c_us(self.freq, 1 + nbytes))
            return _in4(read_b, self, addr, nbytes, stop)
        finally:
            xe()

    _orig["readfrom_mem_into"] = read_mem
    _orig["readfrom_into"] = read_into
    _orig["writeto"] = write
    I2C.readfrom_mem_into = _w_readfrom_mem_into
    I2C.readfrom_mem = readfrom_mem
    I2C.writeto_mem = writeto_mem
    I2C.readfrom_into = _w_readfrom_into
    I2C.readfrom = readfrom
    I2C.writeto = _w_writeto
