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
4. otherwise starts the watchdog and runs the scheduler.

``build()`` does 1-3 and returns the ``Vehicle`` (drivers, parameters,
scheduler with the driver tasks), so the integration adds its tasks in
one line each, e.g. ``v.sched.add("estimator", est.step, MAIN_MS)``.

Ctrl-C at the USB REPL (a person, or the flashing tool) stops the loop,
puts the wings at the safe angle and stops the hardware watchdog, so the
board stays at the REPL instead of resetting a second later.
"""

import gc

from roboray.firmware import boards
from roboray.firmware.drivers import battery as battery_mod
from roboray.firmware.drivers import servo as servo_mod
from roboray.firmware.drivers.battery import Battery
from roboray.firmware.drivers.leak import Leak
from roboray.firmware.drivers.lis3mdl import LIS3MDL
from roboray.firmware.drivers.lsm6dsox import LSM6DSOX
from roboray.firmware.drivers.ms5837 import MS5837
from roboray.firmware.drivers.radio import Radio
from roboray.firmware.drivers.servo import Servo, Wings
from roboray.firmware.param_store import ParamStore
from roboray.firmware.scheduler import Scheduler
from roboray.shared import param_defs
from roboray.shared.params import ParamTable

#: What the application prints first where no build wrote ``build_info``.
UNKNOWN_BANNER = "RoboRay firmware unknown unknown"

#: Loop and task periods, ms.
MAIN_MS = 10        # IMU read + estimator step (100 Hz)
CONTROL_MS = 20     # controller (50 Hz)
DEPTH_MS = 20       # MS5837 state machine: one conversion started per call
RADIO_MS = 10
LEAK_MS = 50
BATTERY_MS = 100
PARAMS_MS = 1000    # saves the parameters when they changed

WDT_TIMEOUT_MS = 1000
PARAM_PATH = "/params.bin"

#: Every parameter the application declares: the shared ones and the drivers'.
PARAMS = param_defs.PARAMS + servo_mod.PARAMS + battery_mod.PARAMS

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
        self.problems = []
        self.warnings = []

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
        """Main-rate task: accelerometer, gyroscope and magnetometer."""
        self.imu.read()
        self.mag.read()

    def build_loop(self, reset_cause=0):
        """The scheduler with the driver tasks (the integration adds its own)."""
        s = Scheduler(self.clock, MAIN_MS, reset_cause=reset_cause)
        s.add("imu", self.read_imu, MAIN_MS)
        s.add("radio", self.radio.service, RADIO_MS)
        s.add("depth", self.depth.update, DEPTH_MS, phase=1)
        s.add("servos", self.wings.update, CONTROL_MS)
        s.add("leak", self.leak.update, LEAK_MS, phase=3)
        s.add("battery", self.battery.update, BATTERY_MS, phase=5)
        s.add("params", self.store.service, PARAMS_MS, phase=7)
        self.sched = s
        return s

    def run(self, cycles=-1):
        """Start the watchdog and run the loop; wings safe when it ends."""
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
    for line in v.problems:
        print(line)
    if not v.problems:
        v.build_loop(machine.reset_cause())
    return v


def main(board=None, cycles=-1, param_path=PARAM_PATH):
    """Start the vehicle; 0 when the loop ended, 1 when it could not start."""
    print(banner())
    try:
        import machine
        import time
    except ImportError as e:
        print("no machine module (%s): this interpreter is not a board" % e)
        return 1
    print("reset cause: %s" % reset_cause_name(machine, machine.reset_cause()))
    try:
        v = build(machine, time, board, param_path)
    except ValueError as e:
        print("cannot start: %s" % e)
        return 1
    if v.problems:
        print("stopped: %d problem(s) above; the vehicle does not run without its sensors"
              % len(v.problems))
        return 1
    print("running: %d tasks, loop %d Hz" % (len(v.sched.names), 1000 // MAIN_MS))
    v.run(cycles)
    return 0
