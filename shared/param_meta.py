"""What each parameter means: display name, units, description, values.

Host-only: the ground station (``roboray-ground param show -v``, ``param
pdef``) reads it; board code never imports it (a test holds to that), so
none of this text is on the board's heap. The board needs only what
``shared/param_defs.py`` and the modules' ``PARAMS`` declare (name, type,
default, range, flags); range and read-only come from there, not from
here, so each fact is kept once. Every declared parameter has an entry and
every entry is a declared parameter (``tests/test_param_meta.py``).

``META[name] = (display name, units, description, values, user)``:

- units: ArduPilot's abbreviations (``UNITS`` spells each out), "" for none;
- values: ``((code, label), ...)`` for a parameter that takes a few codes,
  () otherwise;
- user: "Standard" or "Advanced", as ArduPilot's ``@User``.

The file is plain data, so it also compiles for the board (it is installed
with the rest of ``shared/``), but nothing there imports it.
"""

#: ArduPilot's unit abbreviations used here, spelled out (apm.pdef.xml's UnitText).
UNITS = {
    "s": "seconds",
    "ms": "milliseconds",
    "Hz": "hertz",
    "V": "volt",
    "m": "meters",
    "m/s": "meters per second",
    "deg": "degrees",
    "deg/s": "degrees per second",
    "rad": "radians",
    "1/s": "per second",
    "Pa": "pascal",
    "mGauss": "milligauss",
    "PWM": "PWM in microseconds",
    "kB": "kilobytes",
}

#: A failsafe's action (firmware/failsafe.py ACTIONS).
ACTIONS = ((0, "Off"), (1, "Warn"), (2, "Disarm"), (3, "FAILSAFE mode"))
ENABLED = ((0, "Disabled"), (1, "Enabled"))

META = {}


def _p(name, display, units, description, values=(), user="Standard"):
    META[name] = (display, units, description, values, user)


# ---------------------------------------------------------------- identity, link
_p("SYSID_THISMAV", "MAVLink system ID", "",
   "This vehicle's MAVLink system id; a ground station talks to the vehicle with this id.", user="Advanced")
_p("SYSID_MYGCS", "Ground station MAVLink system ID", "",
   "The ground station's system id: only its heartbeats keep the link-loss failsafe away and only it "
   "may command the vehicle.", user="Advanced")
_p("SERIAL_BAUD", "Radio baud rate", "",
   "Baud rate of the telemetry radio's UART (8N1). Fixed by the board profile; shown for reference.",
   user="Advanced")

# ---------------------------------------------------------------- streams
_STREAMS = (
    ("SR_ATTITUDE", "Attitude stream rate", "ATTITUDE and ATTITUDE_QUATERNION"),
    ("SR_POSITION", "Position stream rate", "LOCAL_POSITION_NED and POSITION_TARGET_LOCAL_NED"),
    ("SR_SENSORS", "Sensor stream rate", "SCALED_PRESSURE and SCALED_IMU"),
    ("SR_SERVO", "Servo stream rate", "SERVO_OUTPUT_RAW"),
    ("SR_BATTERY", "Battery stream rate", "BATTERY_STATUS"),
    ("SR_STATUS", "Status stream rate", "SYS_STATUS, SYSTEM_TIME and the loop figures (NAMED_VALUE_*)"),
)
for _name, _display, _what in _STREAMS:
    _p(_name, _display, "Hz", "How often the vehicle sends %s; 0 stops them. The heartbeat is always 1 Hz." % _what)

# ---------------------------------------------------------------- failsafes
_p("FS_GCS_ENABLE", "Ground link failsafe action", "",
   "What the vehicle does when no ground heartbeat arrived for FS_GCS_TIMEOUT s (after one was seen).",
   ACTIONS)
_p("FS_GCS_TIMEOUT", "Ground link failsafe timeout", "s",
   "Time without a heartbeat from the ground station before the link-loss failsafe acts.")
_p("FS_GCS_DEPTH", "Ground link expected-loss depth", "m",
   "Deeper than this a lost ground link is expected (radio does not carry far through water) and the "
   "link failsafe does not act: the vehicle says 'link lost below N m, expected' once, as it goes below "
   "this depth or finds the link gone there, and 'link regained' when heartbeats return; shallower, "
   "FS_GCS_ENABLE acts as usual, and once it has acted it holds until the link is back. Set it to the "
   "depth the radio holds its link to in the water dived ('roboray-sim radio-reach'): the default is "
   "the buildable vehicle's HC-12 in fresh water (5 m). In salt water (BARO_SPEC_GRAV above 1.01) it "
   "counts as at most 0.1 m, about every radio's reach there. 300 makes every loss act (fresh water).")
_p("FS_LEAK_ENABLE", "Leak failsafe action", "", "What the vehicle does when the leak probe detects water.",
   ACTIONS)
_p("FS_EKF_ACTION", "Estimator failsafe action", "",
   "What the vehicle does when an estimate the mode needs is invalid for 1 s, or two innovation test "
   "ratios exceed FS_EKF_THRESH.", ACTIONS)
_p("FS_EKF_THRESH", "Estimator failsafe threshold", "",
   "Innovation test ratio (compass, depth, position fix) above which a measurement counts against the "
   "estimator.", user="Advanced")
_p("BATT_FS_LOW_ACT", "Low battery failsafe action", "",
   "What the vehicle does when the pack stays below BATT_LOW_VOLT for BATT_LOW_TIMER s, or the battery "
   "monitor fails.", ACTIONS)
_p("BATT_LOW_VOLT", "Low battery voltage", "V", "Pack voltage below which the battery counts as low.")
_p("BATT_LOW_TIMER", "Low battery timer", "s",
   "Time the pack must stay below BATT_LOW_VOLT before the low-battery failsafe acts.")
_p("BATT_PARK", "Park the servos on a low battery", "",
   "1: while the pack is low (below BATT_LOW_VOLT for BATT_LOW_TIMER s) and the vehicle is disarmed, the "
   "servos get no pulses and stop holding the wings, so a vehicle left on the bottom spends its pack on "
   "the electronics only; arming gives them their pulses back. 0: they hold SERVO_SAFE_DEG.",
   ((0, "Hold"), (1, "Park")))
_p("FS_SENSOR_ACT", "Sensor failsafe action", "",
   "What the vehicle does when the IMU or the depth sensor fails.", ACTIONS)
_p("FS_MAG_ACT", "Compass failsafe action", "", "What the vehicle does when the magnetometer fails.", ACTIONS)
_p("FS_DEPTH_MAX", "Maximum depth", "m", "Deepest the vehicle may go before FS_DEPTH_ACT acts; 0 turns the check off.")
_p("FS_DEPTH_ACT", "Maximum depth failsafe action", "", "What the vehicle does beyond FS_DEPTH_MAX.", ACTIONS)
_p("FS_LOOP_MAX", "Loop overrun limit", "",
   "Overrun main-loop slots in one second that raise the loop failsafe.", user="Advanced")
_p("FS_LOOP_ACT", "Loop overrun failsafe action", "",
   "What the vehicle does when FS_LOOP_MAX or more slots overran in a second.", ACTIONS, user="Advanced")
_p("FS_LOCKUP_ACT", "Watchdog reset failsafe action", "",
   "What the vehicle does after the watchdog reset a locked-up board (until the next arming).", ACTIONS,
   user="Advanced")

# ---------------------------------------------------------------- modes
_p("ARMING_CHECK", "Arming checks", "",
   "Run the pre-arm checks (no leak, sensors healthy, battery good, estimates valid) before arming.", ENABLED)
_p("SERVO_SAFE_DEG", "Disarmed wing angle", "deg", "Wing angle held while disarmed.")
_p("PASSIVE_WING_DEG", "PASSIVE wing angle", "deg", "Fixed wing angle of PASSIVE mode.")
_p("FS_WING_DEG", "FAILSAFE wing angle", "deg", "Wing angle of FAILSAFE mode: folded is the fastest descent.")

# ---------------------------------------------------------------- control
_p("CTL_FOLD_DEG", "Mean wing fold", "deg", "Mean wing fold when no descent speed is commanded.")
_p("CTL_POS_P", "Position gain", "1/s",
   "VELOCITY mode: pull towards the moving reference point.")
_p("CTL_POS_LEASH", "Position leash", "m", "VELOCITY mode: farthest the reference point runs ahead of the vehicle.")
_p("CTL_VEL_P", "Velocity feedback gain", "",
   "Feedback of the estimated horizontal velocity error.", user="Advanced")
_p("CTL_VEL_MAX", "Maximum horizontal velocity", "m/s", "Limit of the horizontal velocity set point.")
_p("CTL_TGT_K", "Target glide factor", "",
   "TARGET mode: glide this many times the ratio the target needs.")
_p("CTL_TGT_HMIN", "Target minimum height", "m", "TARGET guidance's smallest height to go.", user="Advanced")
_p("CTL_DEPTH_M", "Default bottom depth", "m", "Bottom depth assumed for a target given without one.")
_p("CTL_DESC_I", "Descent speed integral gain", "",
   "Descent speed loop: radians of fold per metre of descent error.", user="Advanced")
_p("CTL_ATT_P", "Attitude gain", "",
   "ATTITUDE mode: glide ratio per radian of tilt error.", user="Advanced")
_p("CTL_ATT_I", "Attitude integral gain", "",
   "ATTITUDE mode: the integral of the tilt error, glide ratio per radian second.", user="Advanced")
_p("CTL_SLEW_DPS", "Wing slew rate", "deg/s", "Fastest change of a wing command.")
_p("CTL_BS_K", "Backstepping gain", "",
   "Backstepping controller (thesis sec. 4.3): its gain matrix K is this times the identity.", user="Advanced")
_p("CTL_BS_KV2", "Backstepping velocity weight", "",
   "Backstepping controller: K's weight on the y_c velocity.", user="Advanced")

# ---------------------------------------------------------------- servos
for _k in range(1, 5):
    _p("SERVO%d_MIN" % _k, "Servo %d pulse at 0 deg" % _k, "PWM", "Pulse that puts wing %d flat (0 deg)." % _k)
    _p("SERVO%d_MAX" % _k, "Servo %d pulse at 90 deg" % _k, "PWM", "Pulse that folds wing %d (90 deg)." % _k)
    _p("SERVO%d_TRIM" % _k, "Servo %d trim" % _k, "PWM", "Added to both ends of servo %d's pulse range." % _k)
    _p("SERVO%d_REVERSED" % _k, "Servo %d reversed" % _k, "",
       "Reverse servo %d: 0 deg at the SERVO%d_MAX end." % (_k, _k), ((0, "Normal"), (1, "Reversed")))

# ---------------------------------------------------------------- battery
_p("BATT_VOLT_MULT", "Voltage multiplier", "",
   "Pack volts per volt at the ADC pin (the divider's ratio).", user="Advanced")

# ---------------------------------------------------------------- navigation
_p("AHRS_ORIENTATION", "Board orientation", "",
   "How the IMU board is mounted: chip axes to body axes, ArduPilot's numbering.",
   ((0, "None"), (2, "Yaw90"), (4, "Yaw180"), (6, "Yaw270"), (8, "Roll180"), (10, "Roll180Yaw90"),
    (12, "Roll180Yaw180"), (14, "Roll180Yaw270")), user="Advanced")
for _axis in "XYZ":
    _p("INS_POS1_" + _axis, "IMU position %s" % _axis, "m",
       "IMU position from the centre of buoyancy (wings flat), body %s." % _axis, user="Advanced")
for _axis in "XYZ":
    _p("BARO_POS_" + _axis, "Pressure port position %s" % _axis, "m",
       "Pressure port position from the centre of buoyancy (wings flat), body %s." % _axis, user="Advanced")
_p("BARO_SPEC_GRAV", "Water specific gravity", "", "Specific gravity of the water: 1.0 fresh, 1.024 sea.")
_p("BARO1_GND_PRESS", "Surface pressure", "Pa",
   "Pressure at the surface the depth is measured from; set on arming at the surface.")
for _axis in "XYZ":
    _p("COMPASS_OFS_" + _axis, "Compass offset %s" % _axis, "mGauss",
       "Hard-iron offset of the magnetometer, body %s (after AHRS_ORIENTATION, as ArduPilot applies it)."
       % _axis)
for _axis in "XYZ":
    _p("COMPASS_DIA_" + _axis, "Compass soft-iron diagonal %s" % _axis, "",
       "Soft-iron matrix, diagonal %s." % _axis, user="Advanced")
for _axis, _pair in (("X", "xy"), ("Y", "xz"), ("Z", "yz")):
    _p("COMPASS_ODI_" + _axis, "Compass soft-iron off-diagonal %s" % _pair, "",
       "Soft-iron matrix, off-diagonal %s." % _pair, user="Advanced")
_p("COMPASS_DEC", "Magnetic declination", "rad", "Magnetic declination at the dive site.")
_p("VISO_DELAY_MS", "Position fix delay", "ms",
   "Time from a position fix's measurement to its arrival at the vehicle (tracker plus radio).",
   user="Advanced")

# ---------------------------------------------------------------- dead reckoning
_p("DR_GLIDE_K0", "Descent model: glide gain, wings flat", "",
   "How fast the vehicle glides sideways when tilted, per unit descent speed and tangent of the tilt, with "
   "the wings' mean fold at 0 deg (linear in the fold between the rows). The estimator dead-reckons with it "
   "where no position fix arrives. Fit it to your vehicle: roboray-sim identify --params-out.", user="Advanced")
_p("DR_GLIDE_K45", "Descent model: glide gain, 45 deg fold", "",
   "The glide gain (as DR_GLIDE_K0) with the wings' mean fold at 45 deg.", user="Advanced")
_p("DR_GLIDE_K90", "Descent model: glide gain, wings folded", "",
   "The glide gain (as DR_GLIDE_K0) with the wings' mean fold at 90 deg.", user="Advanced")
_p("DR_DIFF_K", "Descent model: differential glide", "",
   "Horizontal glide per unit descent speed per 90 deg of differential fold (wing 1 less wing 3 along x, "
   "wing 2 less wing 4 along y).", user="Advanced")
_p("DR_TAU", "Descent model: lag", "s",
   "Lag of the horizontal velocity behind the descent model's (0: none).", user="Advanced")

# ---------------------------------------------------------------- flight log
_p("LOG_BITMASK", "Log bitmask", "",
   "Which periodic records the on-board log keeps (events, modes, texts and parameters always): "
   "bit 0 ATT, 1 IMU, 2 MAG, 3 BARO, 4 RCOU and WING, 5 EST, 6 PM, 7 FIX.")
_p("LOG_FILE_BUFSIZE", "Log buffer size", "kB",
   "RAM the dive is logged into before it goes to flash (only while the vehicle is still or disarmed): "
   "80 kB holds ~25 s of dive at full rate (~2.4 kB/s), then ~18 s thinned (ATT kept at 25 Hz): a 10 m dive "
   "of either vehicle, nothing dropped. Every kB "
   "adds to each collection's time and takes room the loop's garbage needs between collections.",
   user="Advanced")
_p("LOG_DISARMED", "Log while disarmed", "", "Keep a log while disarmed too, not only from arming to disarming.",
   ENABLED)
