"""The twin inside the interpreter: the emulated board in lockstep with the world.

MicroPython code (the same file runs on CPython in the twin's child process
for ``--interpreter cpython``). ``run()`` puts the three sensors on the
emulated Pico 2's I2C bus, installs the virtual clock's hook and runs the
firmware's own entry point, ``roboray.firmware.app.main()``, again after
every reset, as the board's ``main.py`` would be.

Lockstep. Time moves only when the firmware sleeps (``vclock``); the hook
sees every advance. At each frame boundary (every ``frame_us`` of board
time, 20 ms: one servo frame) it makes one ``hostlink.request``:

- request: ``"<p1> <p2> <p3> <p4> <mode> <failsafes> <hex> <times>"``: the
  four servo pulses (ns, as the PWM outputs show them now), the firmware's
  mode (bits 0-2, ``shared/modes.py``'s number) and armed flag (bit 3)
  and its active failsafe bits (for the twin's record; -1 when no
  application runs), the bytes the radio UART sent since the last frame,
  and the hex of the board-time records since the last frame
  (``boardtime.py``: every task call, collection and slot, in us; empty
  when code is free);
- reply (the twin sent it after the previous request, so it is waiting
  in the pipe: ``runner.py`` runs the world one frame ahead):
  ``"<rows> <hex> <events>"``. ``rows`` is the hex of little-endian
  doubles, 13 a step boundary, for this boundary and the next ``step_us``
  ones within the frame: ``[ax, ay, az, gx, gy, gz, mx, my, mz, p_pa,
  temp_c, v_batt, leak]`` (chip axes; m/s^2, rad/s, gauss, Pa, C, V at the
  pack, 0/1; ``p_pa``, ``v_batt`` and ``leak`` are NaN when unchanged),
  applied to the devices at their boundary (binary: JSON's number parsing
  cost the board four times as much); ``hex`` are bytes for the board's
  radio UART (the line paces them at its baud rate; ``-`` for none);
  ``events`` (JSON) are faults and orders:
  ``["fault", "depth"|"imu"|"mag", kind]`` (``i2c_device.FAULT_*``),
  ``["cut", n]`` (0: the power goes now; else at the n-th flash step of the next parameter
  save), ``["hang"]`` (the loop stops until the watchdog resets the
  board), ``["stall", ms]`` (the board is busy once for ``ms``, unannounced),
  ``["cost", us]`` (every clock reading costs ``us``: an overloaded
  CPU), ``["stop"]`` (end of the run).

A reset (watchdog, ``machine.reset()``, a power cut) ends the application
with a ``BaseException`` the firmware cannot catch; the runner power-cycles
what the reset cuts and starts ``main()`` again. An application that
crashes prints its traceback and leaves the board at the REPL, as on the
board, until its watchdog resets it. The world goes on
meanwhile, and so does the virtual clock: the sensors keep their own time
and the firmware never relies on ticks starting at 0. At the end the
runner reports its counts with one last request, ``"E" + JSON``.
"""

import binascii
import json
import struct
import sys

import hostlink
import machine
import time

from roboray.firmware.param_store import Files
from roboray.sim.twin.board import boardtime, vclock
from roboray.sim.twin.board.lis3mdl_device import LIS3MDLDevice
from roboray.sim.twin.board.lsm6dsox_device import LSM6DSOXDevice
from roboray.sim.twin.board.ms5837_device import MS5837Device
from roboray.sim.twin.board.powercut import PowerCut, PowerCutFiles

SERVO_PINS = (10, 11, 12, 13)
_ROW = 13   # values a step boundary in a reply
UART_ID = 0
ADC_CHANNEL = 0
LEAK_PIN = 15


class Stop(BaseException):
    """The twin ends the run."""


class Lockstep:
    """The clock hook and the devices; see the module docstring."""

    def __init__(self, frame_us=20000, step_us=10000, divider=3.0, board_time=None):
        if frame_us % step_us:
            raise ValueError("frame_us %d is not a multiple of step_us %d" % (frame_us, step_us))
        t = machine.twin
        self.twin = t
        self.depth = t.attach(0, MS5837Device())
        self.imu = t.attach(0, LSM6DSOXDevice())
        self.mag = t.attach(0, LIS3MDLDevice())
        self.devices = {"depth": self.depth, "imu": self.imu, "mag": self.mag}
        self.uart = t.uart(UART_ID)
        self.step_us = step_us
        self.divider = divider
        #: the board's compute time (``boardtime.BoardTime``), or None: free code
        self.bt = board_time
        self.files = self.new_files()
        self._acc = 0
        self._steps = []
        self._k = 0
        # hangs asked for and not yet ended by the watchdog: one arriving
        # while the loop already hangs, or while the board boots (no
        # watchdog yet), hangs the next loop once its watchdog runs, so
        # each ``watchdog`` fault is a reset of its own
        self._hangs = 0
        self._stall_us = 0
        self._inside = False
        self.cost_us = 0
        self.frames = 0
        self.resets = 0
        self.power_cuts = 0
        self.crashes = 0
        self.overruns = 0
        self.stalls = 0
        self.max_loop_us = 0
        self.skipped = 0
        self.task_errors = 0
        self.lives = []
        #: Wall time (us) inside hostlink.request, and between requests (the
        #: firmware and this emulation), summed over the frames.
        self.request_us = 0
        self.board_us = 0
        self._w_end = 0

    def new_files(self):
        """The board's file system, fresh after a power cut; its flash
        writes stall the board when code takes time."""
        f = PowerCutFiles(Files(), 0)
        # a powercut fault cuts at a step of the parameter save (faults.py):
        # the flight log's and the dive state's writes do not count
        f.counted = "params.bin"
        if self.bt is not None:
            f.board_time = self.bt
        return f

    # ------------------------------------------------------------- the hook
    def __call__(self, dt):
        # the clock's hook is this object, not its bound method: the
        # firmware's collector orders what it can see (firmware/collector.py)
        self.hook(dt)

    def hook(self, dt):
        if self._inside:
            return  # the twin's own clock readings (UART pacing, the watchdog)
        self._inside = True
        cost = self.cost_us
        if cost:
            vclock.set_tick_cost_us(0)   # the emulation costs the firmware no time
        try:
            self._acc += dt
            step = self.step_us
            while self._acc >= step:
                self._acc -= step
                self.boundary()
            self.twin.check_watchdog()
            stall = self._stall_us
            if stall:
                # busy without a word to the loop: time passes and the world
                # goes on, the firmware runs again after it
                self._stall_us = 0
                while stall > 0:
                    d = step if stall > step else stall
                    stall -= d
                    vclock.advance(d)
                    self._acc += d
                    while self._acc >= step:
                        self._acc -= step
                        self.boundary()
                    self.twin.check_watchdog()
            while self._hangs and self.twin.wdt_timeout_ms:
                # the loop is stuck: time passes, the world goes on, only the
                # watchdog can end this (check_watchdog raises BoardReset)
                vclock.advance(step)
                self.boundary()
                try:
                    self.twin.check_watchdog()
                except machine.BoardReset:
                    self._hangs -= 1
                    raise
        finally:
            self._inside = False
            if self.cost_us:
                vclock.set_tick_cost_us(self.cost_us)

    def boundary(self):
        """A step boundary: the world's inputs for now, asked for at a frame's start."""
        k = self._k
        if k >= len(self._steps):
            self.request()
            k = 0
        self._k = k + _ROW
        # indexed in place: a slice of the row would be a new tuple (garbage
        # on the board's heap) at every step boundary
        s = self._steps
        # dated at its boundary (now less the time still to step): after a
        # stall the IMU's FIFO batches each sample with its own step's motion
        self.imu.set_motion(s[k], s[k + 1], s[k + 2], s[k + 3], s[k + 4], s[k + 5],
                            (vclock.now_us - self._acc) & 0x3FFFFFFF)
        self.mag.set_field(s[k + 6], s[k + 7], s[k + 8])
        p = s[k + 9]
        if p == p:   # NaN: unchanged
            self.depth.set(p, s[k + 10])
        v = s[k + 11]
        if v == v:
            self.twin.set_adc_volts(ADC_CHANNEL, v / self.divider)
        leak = s[k + 12]
        if leak == leak:
            self.twin.set_pin(LEAK_PIN, int(leak))

    def request(self):
        from roboray.firmware import app
        t = self.twin
        v = app.vehicle
        mode = -1
        active = 0
        if v is not None and v.modes is not None:
            mode = v.modes.mode | (8 if v.modes.armed else 0)
            active = v.failsafes.active
        sent = self.uart.take()
        times = self.bt.take_records() if self.bt is not None else b""
        w0 = vclock.wall_us()
        pulse = t._pulse  # what t.pulse_ns(pin) returns, without four calls
        text = hostlink.request("%d %d %d %d %d %d %s %s" % (
            pulse[SERVO_PINS[0]], pulse[SERVO_PINS[1]], pulse[SERVO_PINS[2]],
            pulse[SERVO_PINS[3]], mode, active, binascii.hexlify(sent).decode() if sent else "",
            binascii.hexlify(times).decode() if times else ""))
        w1 = vclock.wall_us()
        self.request_us += vclock.ticks_diff(w1, w0)
        if self.frames:
            self.board_us += vclock.ticks_diff(w0, self._w_end)
        self._w_end = w1
        rows, down, events = text.split(" ", 2)
        self.frames += 1
        self._steps = struct.unpack("<%dd" % (len(rows) >> 4), binascii.unhexlify(rows))
        self._k = 0
        if down != "-":
            self.uart.feed(binascii.unhexlify(down))
        if events != "[]":
            for e in json.loads(events):
                self.event(e)

    def event(self, e):
        kind = e[0]
        if kind == "fault":
            self.devices[e[1]].set_fault(e[2])
        elif kind == "cut":
            f = self.files
            if e[1]:
                f.cut_at = f.steps + e[1]
            else:
                f.dead = True   # now, wherever the firmware is
                raise PowerCut("power cut")
        elif kind == "hang":
            self._hangs += 1
        elif kind == "stall":
            self._stall_us = e[1] * 1000
        elif kind == "cost":
            self.cost_us = e[1]   # applied when the hook returns
        elif kind == "stop":
            raise Stop()
        else:
            raise ValueError("unknown twin event %r" % (kind,))

    # ------------------------------------------------------------- lives
    def life_ended(self):
        """Add the counts of the application that just ended."""
        import gc

        from roboray.firmware import app
        v = app.vehicle
        app.vehicle = None
        try:
            self._count_life(v)
        finally:
            # a reset clears the board's RAM; here the next life runs in the
            # same heap, so what the last one left must go before it builds
            # (its log ring wants one large block)
            v = None
            if self.bt is not None:
                self.bt._modes = None
            # the collector's chain (collector.prepare) links every instance
            # of the last life: kept, it held ~40 kB of it into the next, which
            # then ran out of a Pico 2's heap at start
            from roboray.firmware import collector
            collector._first = None
            gc.collect()

    def _count_life(self, v):
        if v is None or v.sched is None:
            return
        s = v.sched
        self.overruns += s.overruns
        self.stalls += getattr(s, "stalls", 0)
        self.skipped += s.skipped
        if s.max_loop_us > self.max_loop_us:
            self.max_loop_us = s.max_loop_us
        errors = 0
        for i in range(len(s.names)):
            errors += s.task_errors[i]
        self.task_errors += errors
        self.lives.append([s.cycles, s.overruns, s.max_loop_us, errors])

    def report(self):
        bt = self.bt
        return {"frames": self.frames, "resets": self.resets, "power_cuts": self.power_cuts,
                "task_names": bt.names if bt is not None else [],
                "records_lost": bt.lost if bt is not None else 0,
                "flash_stall_us": bt.flash_us if bt is not None else 0,
                "crashes": self.crashes,
                "overruns": self.overruns, "stalls": self.stalls, "skipped": self.skipped, "max_loop_us": self.max_loop_us,
                "task_errors": self.task_errors, "lives": self.lives,
                "request_us": self.request_us, "board_us": self.board_us}


def _print_exception(e):
    pe = getattr(sys, "print_exception", None)
    if pe is not None:
        pe(e)
    else:  # CPython
        import traceback
        traceback.print_exception(type(e), e, e.__traceback__, file=sys.stdout)


def _board_time(config):
    """``boardtime.BoardTime`` from the twin's ``board_time`` settings, the
    emulation bracketed on the emulated RP2350, and the scheduler
    instrumented as each life's loop starts."""
    if not config:
        return None
    bt = boardtime.BoardTime(config["source"], config.get("model"), config.get("cpu_mhz", boardtime.REF_MHZ),
                             config.get("ps_per_insn"), config.get("heap", False))
    # the firmware reads the clock it runs at (its tasks' budgets scale with it)
    machine.set_boot_freq(int(bt.cpu_mhz * 1000000 + 0.5))
    if bt.source == "emu":
        boardtime.bracket_emulation(machine, bt)
    global _bt, _run_loop
    from roboray.firmware.scheduler import Scheduler
    _bt = bt
    if _run_loop is None:
        _run_loop = Scheduler.run
    Scheduler.run = _run_instrumented
    return bt


# The board time and the scheduler's own run() while a twin runs: module
# globals and a plain function, not a closure, so the firmware's collector
# sees what they hold (firmware/collector.py).
_bt = None
_run_loop = None


def _run_instrumented(sched, cycles=-1):
    from roboray.firmware import app
    bt = _bt
    v = app.vehicle
    if bt.source == "emu":
        boardtime.emuboard.exclude_begin()   # the twin's own set-up, not the board's
    try:
        bt.instrument(sched, v.modes if v is not None else None)
    finally:
        if bt.source == "emu":
            boardtime.emuboard.exclude_end()
    return _run_loop(sched, cycles)


def run(param_path="/params.bin", frame_us=20000, step_us=10000, divider=3.0, board=None, board_time=None):
    """Run the firmware in lockstep until the world says stop; the report.

    ``board_time``: None (code is free: time moves only when the firmware
    sleeps) or ``{"source": "emu"|"model", "model": {...}, "cpu_mhz": 150,
    "ps_per_insn": N, "heap": bool}`` (``boardtime.py``; ``heap``: count
    each task call's heap bytes).

    The application is imported here and where it is used, not at the
    module's top: the twin's objects then lead to the firmware's only
    through what the firmware holds of them (its clock, its peripherals),
    which the firmware's collector can order (``firmware/collector.py``)."""
    from roboray.firmware import app
    bt = _board_time(board_time)
    ls = Lockstep(frame_us, step_us, divider, bt)
    ls.boundary()      # the world's inputs at time 0, before anything runs
    vclock.set_hook(ls)
    if bt is not None:
        bt.start()
    try:
        while True:
            app.vehicle = None
            try:
                app.main(board=board, param_path=param_path, fs=ls.files)
                ls.life_ended()
                # the application stopped and said why; the board sits at the
                # REPL while the world goes on
                while True:
                    time.sleep_ms(ls.step_us // 1000)
            except machine.BoardReset:
                ls.life_ended()
                ls.resets += 1
                ls.cost_us = 0
                vclock.set_tick_cost_us(0)
            except Exception as e:  # noqa: BLE001 - the application crashed
                # as on the board: the traceback on the console, the REPL,
                # and the watchdog (if the loop had started it) resets the
                # board a second later
                _print_exception(e)
                ls.life_ended()
                ls.crashes += 1
                try:
                    while True:
                        time.sleep_ms(ls.step_us // 1000)
                except machine.BoardReset:
                    ls.resets += 1
            except PowerCut:
                ls.life_ended()
                ls.power_cuts += 1
                ls.twin.power_cycle(machine.PWRON_RESET)
                ls.files = ls.new_files()
                ls.cost_us = 0
                vclock.set_tick_cost_us(0)
    except Stop:
        ls.life_ended()
    finally:
        if bt is not None:
            bt.stop()
        vclock.set_hook(None)
        vclock.set_tick_cost_us(0)
    report = ls.report()
    hostlink.request("E" + json.dumps(report))
    return report
