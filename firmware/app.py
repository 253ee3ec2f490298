"""The RoboRay application: start-up, hardware probe, then the main loop.

``main()`` is what ``/main.py`` runs after every reset:

1. prints the start-up line, ``build_info.BANNER`` (``RoboRay firmware
   <version> <revision>``, written by ``roboray-flash build``; ``RoboRay
   firmware unknown unknown`` where no build wrote it), before it touches
   any hardware, then the reset cause;
2. loads the board profile (``firmware/boards/``) and the parameters from
   flash (``param_store``), and puts the wings at the safe angle;
3. probes every sensor on the I2C bus. When one does not answer or answers
   wrongly it prints one line per device (which part, which bus and
   address, what to check) and stops, returning 1, without a traceback:
   the vehicle does not run without its sensors;
4. builds the flight layer: ``Navigation`` (the estimator and its inputs),
   ``Failsafes`` (arming checks and failsafes), ``Modes``, the MAVLink
   ``Link`` on the radio, ``Flight`` (modes to wing commands, with the
   controller of ``shared/control`` when the firmware has one) and
   ``Resume`` (the dive's state in the watchdog's scratch words and on
   flash, ``STATE_FILE`` beside the parameters: a dive survives a reset);
5. starts the watchdog and runs the scheduler with nine tasks:

   ========  ======  ======================================================
   task      period  work
   ========  ======  ======================================================
   nav       10 ms   IMU and magnetometer bursts, estimator step (100 Hz)
   link      10 ms   radio bytes, MAVLink in and out, telemetry
   depth     20 ms   MS5837 conversion collected and the next started;
                     a fresh pressure to the estimator (phase 1)
   control   20 ms   failsafes (10 Hz), mode, controller (50 Hz), servos;
                     the dive's state kept on events, restored after a
                     reset under water (``firmware/resume.py``)
   leak      50 ms   leak probe, debounced
   battery   100 ms  pack voltage, filtered
   params    1 s     saves the parameters when they changed
   log       20 ms   the flight log: records to RAM, to flash only when the
                     vehicle is still or disarmed (phase 1;
                     ``firmware/flightlog/``)
   gc        300 ms  ``collector.collect()``, a planned stall (phase 9: no
                     control), in a slot with nav only; stock MicroPython
                     only (below)
   ========  ======  ======================================================

   Which MicroPython it runs on decides the collection, and it says which
   once, in a STATUSTEXT beside the banner (``collector.floats_boxed()``).
   Stock MicroPython boxes every float result (~3.5 kB of garbage a slot)
   and keeps the "gc" task: ``MicroPython 1.29: floats boxed, GC every 300
   ms``. RoboRay's build keeps a float in the object word and a flight
   slot leaves a few bytes (``roboray-sim bench board``), so it has no "gc"
   task: ``RoboRay MicroPython 1.29: no GC in flight``. The log task
   collects at rest (disarmed, or armed and still on the bottom) in a slot
   its flash write stalls anyway, at most once a second, or when half the
   heap's estimate is used; in flight only when the estimate
   (``collector.Collections``: slots since the last collection, no heap
   walk) runs low, then with a STATUSTEXT and a log MSG ``Heap low:
   collected in flight``.

   Why the collection is a task: on a Pico 2 one ``gc.collect()`` walks
   the whole live heap, tens of ms (counted on the emulated RP2350;
   ``docs/design/board-time.md``), so the loop cannot collect every slot
   as it did (it overran every slot and the watchdog reset the board).
   The loop leaves ~3.5 kB of garbage a slot (boxed floats, 16 bytes
   each), ~5 kB in TARGET: 30 slots of it fit the heap with room to spare,
   so a collection every 300 ms never lets the heap fill (an allocation
   that finds it full would collect in the middle of a task). It runs in
   an odd slot, where the controller does not, with nav only (the
   scheduler's planned-stall task: the others wait for their next turn),
   and is announced as the stall it is: the slots it spans are skipped and
   counted, not taken for a loop in trouble. ``firmware/collector.py``
   orders the heap for the collector once before the loop, so its mark
   stack does not overflow (a second scan of the whole heap); ``build()``
   collects first, so the vehicle's objects take the lowest free blocks
   (the sweep walks the heap up to the highest block in use).

``build()`` does 1-4 and returns the ``Vehicle``; ``main()`` keeps it in
``vehicle`` while it runs, so the REPL (after Ctrl-C) and the twin can
read its state.

Ctrl-C at the USB REPL (a person, or the flashing tool) stops the loop,
puts the wings at the safe angle and stops the hardware watchdog, so the
board stays at the REPL instead of resetting a second later.
"""

import gc

from roboray.firmware import boards
from roboray.firmware import collector
from roboray.firmware.drivers import battery as battery_mod
from roboray.firmware.drivers import servo as servo_mod
from roboray.firmware.drivers.battery import Battery
from roboray.firmware.drivers.leak import Leak
from roboray.firmware.drivers.lis3mdl import LIS3MDL
from roboray.firmware.drivers.lsm6dsox import LSM6DSOX
from roboray.firmware.drivers.ms5837 import MS5837
from roboray.firmware.drivers.radio import Radio
from roboray.firmware.drivers.servo import Servo, Wings
from roboray.firmware import failsafe as failsafe_mod
from roboray.firmware import navigation as navigation_mod
from roboray.firmware.failsafe import Failsafes
from roboray.firmware.flash_record import FlashRecord
from roboray.firmware.flight import Flight
from roboray.firmware.flightlog import logger as flightlog_mod
from roboray.firmware.flightlog.files import LogFiles
from roboray.firmware.flightlog.logger import FlightLog
from roboray.firmware.flightlog.transfer import LogTransfer
from roboray.firmware.link import Link
from roboray.firmware.navigation import Navigation
from roboray.firmware.param_store import ParamStore
from roboray.firmware.resume import Resume
from roboray.firmware.scheduler import Scheduler
from roboray.firmware.telemetry import Reporter
from roboray.shared import modes as modes_mod
from roboray.shared import param_defs
from roboray.shared.mavlink.telemetry import Telemetry
from roboray.shared.params import ParamTable

try:
    from roboray.shared import control as control_mod
except ImportError:  # a firmware without a controller flies PASSIVE and FAILSAFE only
    control_mod = None

#: What the application prints first where no build wrote ``build_info``.
UNKNOWN_BANNER = "RoboRay firmware unknown unknown"

#: Loop and task periods, ms.
MAIN_MS = 10        # IMU read + estimator step (100 Hz)
CONTROL_MS = 20     # controller (50 Hz)
DEPTH_MS = 20       # MS5837 state machine: one conversion started per call
RADIO_MS = 10
LOG_MS = 20         # the flight log (50 Hz calls: ATT and IMU at 25 Hz, the rest slower)
LEAK_MS = 50
BATTERY_MS = 100
PARAMS_MS = 1000    # saves the parameters when they changed
GC_MS = 300         # the collection (see the table above)
#: The radio's unit of work at most on a Pico 2 (bench board: p99 1.6-2.0
#: ms, max 2.9 ms in target-landing): less left in a slot and it waits for
#: the next.
LINK_BUDGET_US = 3000
#: The log's unit of work at most on a Pico 2 (bench board: p99 1.5 ms, max
#: 2.4 ms; its flushes are planned stalls, announced): its budget (a
#: budget under its maximum let a long call end a slot past 10 ms).
LOG_COST_US = 2500
#: The CPU clock the budgets above were measured at (MHz, the Pico 2's).
#: A board clocked slower takes longer for the same work: the budgets
#: scale with ``machine.freq()``. Unscaled at 125 MHz, the log (3.2 ms
#: there) was let into a slot on its 2.5 ms budget and ended it 9.8 ms in
#: (an overrun on the emulated RP2350, bench board --cpu-mhz 125).
BUDGET_MHZ = 150
GC_PHASE = 9
#: What a collection may take on a Pico 2 (measured 42 ms for the firmware
#: alone, up to 76 ms in the twin, whose own objects share the heap), with
#: margin: a slot later than this is an overrun after all.
GC_STALL_MS = 100

WDT_TIMEOUT_MS = 1000
PARAM_PATH = "/params.bin"
#: The dive's state on flash (``firmware/resume.py``), beside the parameters.
STATE_FILE = "dive.bin"

#: Every parameter the application declares: the shared ones, the drivers',
#: navigation's, the failsafes' and the controller's.
PARAMS = (param_defs.PARAMS + servo_mod.PARAMS + battery_mod.PARAMS + navigation_mod.PARAMS
          + failsafe_mod.PARAMS + flightlog_mod.PARAMS + (getattr(control_mod, "PARAMS", ()) if control_mod is not None else ()))

#: The running vehicle (set by ``main()``), for the REPL and the twin.
vehicle = None

_DEG = 0.017453292519943295

#: Sensors on the I2C bus: role, part, driver, profile address name, what to check.
_SENSORS = (
    ("depth", "depth sensor MS5837-30BA", MS5837, "MS5837_ADDR",
     "its cable through the dome and its 3.3 V supply"),
    ("imu", "accelerometer/gyroscope LSM6DSOX", LSM6DSOX, "LSM6DSOX_ADDR",
     "the 9-DoF board's cable and its 3.3 V supply"),
    ("mag", "magnetometer LIS3MDL", LIS3MDL, "LIS3MDL_ADDR",
     "the 9-DoF board's cable and its 3.3 V supply"),
)


def banner():
    """The start-up line of this build."""
    try:
        from roboray.firmware import build_info
        return build_info.BANNER
    except (ImportError, AttributeError):
        return UNKNOWN_BANNER


def _impl():
    """The interpreter, as the start-up STATUSTEXT names it."""
    import sys
    i = sys.implementation
    return "%s %d.%d" % ("MicroPython" if i.name == "micropython" else i.name, i.version[0], i.version[1])


def clock_mhz(machine):
    """The CPU's clock in MHz (``machine.freq()``); BUDGET_MHZ where the port cannot say."""
    freq = getattr(machine, "freq", None)
    hz = freq() if freq is not None else 0
    mhz = (hz + 500000) // 1000000 if isinstance(hz, int) else 0
    return mhz if mhz > 0 else BUDGET_MHZ


def reset_cause_word(machine, cause):
    """``"watchdog"``, ``"power"`` or ``"other"``: what ``Resume`` says."""
    if cause == getattr(machine, "WDT_RESET", -1):
        return "watchdog"
    if cause == getattr(machine, "PWRON_RESET", -1):
        return "power"
    return "other"


def reset_cause_name(machine, cause):
    for name in ("PWRON_RESET", "WDT_RESET", "HARD_RESET", "SOFT_RESET", "DEEPSLEEP_RESET"):
        if getattr(machine, name, None) == cause:
            return name
    return "unknown (%r)" % (cause,)


class Vehicle:
    """One vehicle's hardware, parameters and loop, as ``build()`` made them.

    Drivers (None until built): ``wings``, ``depth``, ``imu``, ``mag``,
    ``radio``, ``battery``, ``leak``; ``params`` and ``store``; ``sched``;
    ``problems``: one line per device that keeps the vehicle from running.
    """

    def __init__(self, machine, profile, clock, params, store):
        self.machine = machine
        self.profile = profile
        self.clock = clock
        self.params = params
        self.store = store
        self.wings = None
        self.depth = None
        self.imu = None
        self.mag = None
        self.radio = None
        self.battery = None
        self.leak = None
        self.sched = None
        self.wdt = None
        self.nav = None
        self.telemetry = None
        self.failsafes = None
        self.modes = None
        self.link = None
        self.flight = None
        self.controller = None
        self.reporter = None
        self.resume = None
        self.log = None
        self.problems = []
        self.warnings = []
        #: False on RoboRay's build (floats in the object word); and then
        #: ``collections``, when it collects (``collector.Collections``).
        self.floats_boxed = True
        self.collections = None
        self.collection_text = ""

    def _param(self, name, default):
        i = self.params.index(name)
        return self.params.get(i) if i >= 0 else default

    def start_outputs(self):
        """Wings to the safe angle; radio, battery and leak inputs."""
        m = self.machine
        p = self.profile
        safe = self._param("SERVO_SAFE_DEG", 0.0) * _DEG
        self.wings = Wings([Servo(pwm) for pwm in p.servo_pwms(m)], safe)
        try:
            self.wings.configure(self.params)
        except ValueError as e:
            self.problems.append("servo calibration: %s; fix the SERVOn_* parameters" % e)
        self.wings.hold_safe()
        self.radio = Radio(p.uart(m))
        adc = p.battery_adc(m)
        self.battery = Battery(adc, divider=self._param("BATT_VOLT_MULT", 3.0),
                               vref=p.ADC_VREF, period_s=BATTERY_MS / 1000.0, clock=self.clock)
        self.leak = Leak(p.leak_pin(m), active_high=p.LEAK_ACTIVE_HIGH, clock=self.clock)
        if not self.battery.update():
            self.warnings.append(
                "battery: ADC%d (GP%d) reads %d of 65535, no pack voltage; the low-battery "
                "failsafe cannot work until a pack is connected through the divider"
                % (p.BATTERY_ADC_PIN - 26, p.BATTERY_ADC_PIN, adc.read_u16()))

    def probe_sensors(self):
        """Start every I2C sensor; a line in ``problems`` for each that fails."""
        p = self.profile
        try:
            i2c = p.i2c(self.machine)
            found = i2c.scan()
        except (OSError, ValueError) as e:
            self.problems.append("sensor bus %s cannot start: %s; check the board profile %s"
                                 % (p.i2c_name(), e, p.NAME))
            return
        for attr, part, driver, addr_name, hint in _SENSORS:
            address = getattr(p, addr_name)
            try:
                setattr(self, attr, driver(i2c, address, clock=self.clock))
            except OSError as e:
                check = hint if address in found else hint + ", and the bus wiring and pull-ups"
                self.problems.append("MISSING %s on %s: %s; check %s" % (part, p.i2c_name(), e, check))
        if not found:
            self.problems.append("nothing at all answers on %s: check SDA/SCL wiring and the pull-ups"
                                 % p.i2c_name())

    def read_imu(self):
        """Accelerometer, gyroscope and magnetometer alone (the benchmark's task)."""
        self.imu.read()
        self.mag.read()

    def build_flight(self, reset_cause=0):
        """Estimator, failsafes, modes, MAVLink and control over the drivers."""
        m = self.machine
        try:
            nav = Navigation(self.imu, self.mag, self.depth, self.params, self.clock)
        except ValueError as e:
            self.problems.append("navigation: %s" % e)
            return
        self.nav = nav
        t = Telemetry()
        self.telemetry = t
        fs = Failsafes(self.params, nav, self.leak, self.battery, None, self.clock,
                       watchdog_reset=reset_cause == getattr(m, "WDT_RESET", -1))
        fs.telemetry = t
        self.failsafes = fs
        modes = modes_mod.Modes(fs)
        fs.modes = modes
        self.modes = modes
        reporter = Reporter(t, nav, self.wings, self.battery, None)
        self.reporter = reporter
        link = Link(self.radio, self.params, modes, t, nav, reporter, self.store, m, self.clock)
        fs.link = link.ep
        self.link = link
        if control_mod is not None:
            self.controller = control_mod.Controller(self.params)
            fs.has_controller = True
        self.flight = Flight(modes, self.wings, nav, fs, link.ep, t, self.params, self.clock, self.controller)
        path = self.store.path
        record = FlashRecord(path[:path.rfind("/") + 1] + STATE_FILE, self.store.fs)
        scratch_of = getattr(self.profile, "scratch", None)
        cause = reset_cause_word(m, reset_cause)
        self.resume = Resume(nav, modes, t, link.ep, self.params, scratch_of(m) if scratch_of else None,
                             record, cause, self.clock)
        print(self.resume.describe())
        link.on_reboot = self.resume.mark_reboot
        if self.resume.cause == "reboot":
            fs.commanded_reset()
        # the flight log beside the parameters: /logs on the board
        files = LogFiles(self.store.fs, root=path[:path.rfind("/") + 1] + "logs")
        # its ring in the RAM the build keeps across a watchdog reset, if any
        ram_of = getattr(self.profile, "log_ram", None)
        self.log = FlightLog(self.params, t, files, self.clock.ticks_us, self.clock.ticks_diff,
                             refresh=reporter.refresh, fixes=link.ep, ram=ram_of(m) if ram_of else None,
                             watchdog_reset=reset_cause == getattr(m, "WDT_RESET", -1))
        print(self.log.describe())
        want = self.params.get_int(self.params.index("LOG_FILE_BUFSIZE"))
        if self.log.ring_kb != want and self.log.ram is None:
            print("log: a %d kB ring, the heap has no %d kB block free (LOG_FILE_BUFSIZE)"
                  % (self.log.ring_kb, want))
        link.ep.logs = LogTransfer(link.ep, files, self._armed, on_erase=self.log.erased, hidden=self.log.prepared,
                                   unflushed=self.log.unflushed)
        link.ep.on_text = self.log.msg
        # a parameter set mid-dive takes effect at once; its flash save waits
        # for the flight log's rule (disarmed, or still on the bottom)
        self.store.may_write = self.log.resting
        self.store.on_hold = self._params_held
        # the build, first thing on the link and in the log, as ArduPilot
        # sends its version: a ground station sees which firmware it talks
        # to, and that the board has (re)started
        link.ep.send_text(6, banner())    # MAV_SEVERITY_INFO

    def build_loop(self, reset_cause=0):
        """The scheduler with the vehicle's nine tasks."""
        s = Scheduler(self.clock, MAIN_MS, reset_cause=reset_cause, collect=False)
        s.add("nav", self.nav.step, MAIN_MS)
        # control right after the estimate it uses; the tasks on a budget
        # (the radio, the log) after every task on none, so that when one
        # asks whether it fits, what the slot still has to do is done: in a
        # slot the compass step and the controller have filled it waits for
        # the next (its bytes wait in the UART). With the battery after the
        # radio, a slot the radio was judged to fit ended 9.9 ms in on the
        # emulated Pico 2, and the scheduler's own time between tasks made
        # it an overrun.
        s.add("control", self.control, CONTROL_MS)
        s.add("depth", self.nav.depth_step, DEPTH_MS, phase=1)
        s.add("leak", self.leak.update, LEAK_MS, phase=3)
        s.add("battery", self.battery.update, BATTERY_MS, phase=5)
        s.add("params", self.store.service, PARAMS_MS, phase=7)
        mhz = clock_mhz(self.machine)
        s.add("link", self.link.step, RADIO_MS, budget_us=LINK_BUDGET_US * BUDGET_MHZ // mhz)
        # the log in the odd slots, away from the controller's even ones, on
        # a budget of its longest call: a slot that nav, depth and the radio
        # filled passes it to the next
        s.add("log", self.log_step, LOG_MS, phase=1, budget_us=LOG_COST_US * BUDGET_MHZ // mhz)
        # Which MicroPython this is decides when the loop collects (see the
        # module docstring). Stock: every GC_MS, announced as the stall it
        # is, in a slot with nav only; collector.collect, not a method of
        # the vehicle: the collector's order (firmware/collector.py) cannot
        # see into a bound method. RoboRay's build: log_step collects at
        # rest, and in flight only when the heap's estimate is low.
        self.floats_boxed = collector.floats_boxed()
        if self.floats_boxed:
            s.add("gc", collector.collect, GC_MS, phase=GC_PHASE, stall_ms=GC_STALL_MS)
            text = "%s: floats boxed, GC every %d ms" % (_impl(), GC_MS)
        else:
            gc.collect()
            self.collections = collector.Collections(gc.mem_free())
            text = "RoboRay %s: no GC in flight" % _impl()
        # said once, on the link and in the log, beside the build's banner
        self.collection_text = text
        self.link.ep.send_text(6, text)    # MAV_SEVERITY_INFO
        self.sched = s
        self.store.expect_delay = s.expect_delay_ms
        self.resume.record.expect_delay = s.expect_delay_ms
        self.failsafes.sched = s
        self.reporter.sched = s
        self.log.expect_delay = s.expect_delay_ms
        self.log.sched = s
        self.link.ep.logs.expect_delay = s.expect_delay_ms
        return s

    def _armed(self):
        return self.modes.armed

    def _params_held(self, held):
        """The parameter save waits (armed, moving) or was made."""
        self.resume.params_held(held)
        if held:
            self.link.ep.send_text(5, "Params: saved once disarmed or at rest")    # MAV_SEVERITY_NOTICE

    def log_step(self):
        """The flight log's task: records to RAM, to flash when harmless;
        on RoboRay's build, the collection when one is due (see
        ``build_loop``)."""
        m = self.modes
        log = self.log
        chunks = log.chunks
        # MODE records carry HEARTBEAT's custom_mode, as ArduPilot's
        log.step(m.armed, modes_mod.CUSTOM[m.mode])
        c = self.collections
        if c is not None:
            slot = self.sched.slot
            k = c.due(slot, log.resting(), log.chunks != chunks)
            if k:
                self.sched.expect_delay_ms(GC_STALL_MS)
                collector.collect()
                if k == 2:
                    # the estimate ran out in flight: a stall the pilot and
                    # the log hear of (MAV_SEVERITY_WARNING; the text goes
                    # to the log as a MSG)
                    c.done(slot, -1, True)
                    self.link.ep.send_text(4, "Heap low: collected in flight")
                else:
                    # at rest the heap may be walked: the free heap read
                    # again for the next estimate
                    c.done(slot, gc.mem_free(), False)

    def control(self):
        """The control task: the flight step, then the dive's state kept
        (``Resume``: saved only when an event changed it)."""
        self.flight.step()
        self.resume.update()

    def run(self, cycles=-1):
        """Start the watchdog and run the loop; wings safe when it ends."""
        # the collector's marking order, before the watchdog runs: the walk
        # takes a few hundred ms on a Pico 2 (firmware/collector.py)
        collector.prepare()
        self.wdt = self.machine.WDT(timeout=WDT_TIMEOUT_MS)
        self.sched.wdt = self.wdt
        gc.collect()
        try:
            self.sched.run(cycles)
        except KeyboardInterrupt:
            self.profile.stop_watchdog(self.machine)
            print("stopped at the REPL: watchdog off, wings safe")
            raise
        finally:
            self.wings.hold_safe()


def build(machine, clock, board=None, param_path=PARAM_PATH, fs=None):
    """Profile, parameters, outputs, sensors and loop; prints each step.

    Returns the ``Vehicle``; when ``vehicle.problems`` is not empty the loop
    was not built and the vehicle must not run.
    """
    # what the imports left behind goes first: the vehicle's objects, which
    # live as long as it does, then take the lowest free blocks, and the
    # collector's sweep, which walks the heap up to the highest block in
    # use, stays short
    gc.collect()
    profile = boards.load(board)
    print("board: %s (%s)" % (profile.NAME, profile.DESCRIPTION))
    params = ParamTable(PARAMS)
    store = ParamStore(params, param_path, fs)
    try:
        store.load()
        print(store.describe())
    except OSError as e:
        print("params: flash unreadable (%s); running on defaults" % e)
    v = Vehicle(machine, profile, clock, params, store)
    v.start_outputs()
    v.probe_sensors()
    for line in v.warnings:
        print("WARNING " + line)
    if not v.problems:
        v.build_flight(machine.reset_cause())
    for line in v.problems:
        print(line)
    if not v.problems:
        v.build_loop(machine.reset_cause())
    return v


def main(board=None, cycles=-1, param_path=PARAM_PATH, fs=None):
    """Start the vehicle; 0 when the loop ended, 1 when it could not start.

    ``fs`` is the file system the parameters are kept on (the board's by
    default; the twin passes one that can lose power mid-save).
    """
    global vehicle
    print(banner())
    try:
        import machine
        import time
    except ImportError as e:
        print("no machine module (%s): this interpreter is not a board" % e)
        return 1
    print("reset cause: %s" % reset_cause_name(machine, machine.reset_cause()))
    try:
        v = build(machine, time, board, param_path, fs)
    except ValueError as e:
        print("cannot start: %s" % e)
        return 1
    if v.problems:
        print("stopped: %d problem(s) above; the vehicle does not run without its sensors"
              % len(v.problems))
        return 1
    print("running: %d tasks, loop %d Hz" % (len(v.sched.names), 1000 // MAIN_MS))
    vehicle = v
    v.run(cycles)
    return 0
