"""The vehicle's parameters, declared in one place.

Each group is a tuple of ``(name, type, default, min, max[, flags])``
entries (see ``shared/params.py``); ``PARAMS`` is what the firmware builds
its ``ParamTable`` from. A module that needs parameters of its own (the
controller's gains, say) declares its group beside these and the firmware
concatenates: ``ParamTable(param_defs.PARAMS + controller.PARAMS)``.
Names follow ArduPilot's where one exists, so parameter files and habits
carry over.
"""

from roboray.shared.params import READ_ONLY, TYPE_INT32, TYPE_REAL32, TYPE_UINT8

#: Identity and link.
LINK = (
    ("SYSID_THISMAV", TYPE_UINT8, 1, 1, 255),        # our MAVLink system id
    ("SYSID_MYGCS", TYPE_UINT8, 255, 1, 255),         # the ground station's system id
    ("SERIAL_BAUD", TYPE_INT32, 57600, 1200, 921600, READ_ONLY),  # radio UART, baud
)

#: Telemetry stream rates in Hz (0 = off); the heartbeat is always 1 Hz.
STREAMS = (
    ("SR_ATTITUDE", TYPE_REAL32, 4.0, 0.0, 50.0),    # ATTITUDE, ATTITUDE_QUATERNION
    ("SR_POSITION", TYPE_REAL32, 2.0, 0.0, 50.0),    # LOCAL_POSITION_NED, POSITION_TARGET_LOCAL_NED
    ("SR_SENSORS", TYPE_REAL32, 1.0, 0.0, 50.0),     # SCALED_PRESSURE, SCALED_IMU
    ("SR_SERVO", TYPE_REAL32, 2.0, 0.0, 50.0),       # SERVO_OUTPUT_RAW
    ("SR_BATTERY", TYPE_REAL32, 0.5, 0.0, 10.0),     # BATTERY_STATUS
    ("SR_STATUS", TYPE_REAL32, 1.0, 0.0, 10.0),      # SYS_STATUS, SYSTEM_TIME, NAMED_VALUE_FLOAT
)

#: Failsafes (issue 9 uses these): enables, time-outs and actions.
FAILSAFE = (
    # actions (firmware/failsafe.py): 0 off, 1 warn, 2 disarm, 3 FAILSAFE mode
    ("FS_GCS_ENABLE", TYPE_UINT8, 1, 0, 3),          # action when the ground falls silent
    ("FS_GCS_TIMEOUT", TYPE_REAL32, 5.0, 1.0, 120.0),  # s without a ground heartbeat
    # m: deeper than this a lost link is expected and only reported (issue 27): the
    # buildable vehicle's HC-12 holds its link to 5.2 m in fresh water (sim/radio)
    ("FS_GCS_DEPTH", TYPE_REAL32, 5.0, 0.0, 300.0),
    ("FS_LEAK_ENABLE", TYPE_UINT8, 3, 0, 3),         # action on a leak
    ("FS_EKF_ACTION", TYPE_UINT8, 3, 0, 3),          # action when the estimate is invalid
    ("FS_EKF_THRESH", TYPE_REAL32, 0.8, 0.1, 5.0),   # estimator innovation ratio that trips it
    ("BATT_FS_LOW_ACT", TYPE_UINT8, 1, 0, 3),        # action on a low battery
    ("BATT_LOW_VOLT", TYPE_REAL32, 6.6, 0.0, 30.0),  # V, low-battery threshold
)

#: Mode logic (shared/modes.py): wing angles of the fixed configurations, in degrees.
MODES = (
    ("ARMING_CHECK", TYPE_UINT8, 1, 0, 1),           # run the pre-arm checks
    ("SERVO_SAFE_DEG", TYPE_REAL32, 0.0, -90.0, 90.0),     # DISARMED
    ("PASSIVE_WING_DEG", TYPE_REAL32, 45.0, -90.0, 90.0),  # PASSIVE
    ("FS_WING_DEG", TYPE_REAL32, 90.0, -90.0, 90.0),       # FAILSAFE: folded, fastest descent
)

#: Control (shared/control/): gains and limits of the cascade controller
#: (and of the thesis's backstepping controller, for comparison).
CONTROL = (
    ("CTL_FOLD_DEG", TYPE_REAL32, 45.0, 30.0, 45.0),     # mean wing fold without a descent-speed command
    ("CTL_POS_P", TYPE_REAL32, 0.5, 0.0, 5.0),          # VELOCITY: 1/s, pull towards the moving reference point
    ("CTL_POS_LEASH", TYPE_REAL32, 1.0, 0.05, 10.0),     # VELOCITY: m, farthest the reference point runs ahead
    ("CTL_VEL_P", TYPE_REAL32, 0.0, 0.0, 10.0),          # feedback of the estimated velocity error (-)
    ("CTL_VEL_MAX", TYPE_REAL32, 0.25, 0.01, 1.0),       # m/s, horizontal velocity set point limit
    ("CTL_TGT_K", TYPE_REAL32, 2.0, 1.0, 10.0),          # TARGET: glide K times the ratio the target needs
    ("CTL_TGT_HMIN", TYPE_REAL32, 1.0, 0.1, 20.0),       # m, TARGET guidance's smallest height to go
    ("CTL_DEPTH_M", TYPE_REAL32, 10.0, 0.5, 300.0),      # m, bottom depth of a target given without one
    ("CTL_DESC_I", TYPE_REAL32, 2.0, 0.0, 20.0),         # descent speed loop, rad of fold per m of error
    ("CTL_ATT_P", TYPE_REAL32, 4.0, 0.0, 50.0),          # ATTITUDE: glide ratio per rad of tilt error
    ("CTL_ATT_I", TYPE_REAL32, 4.0, 0.0, 50.0),          # ATTITUDE: its integral, per rad s
    ("CTL_SLEW_DPS", TYPE_REAL32, 60.0, 10.0, 1000.0),   # deg/s, fastest wing command change
    ("CTL_BS_K", TYPE_REAL32, 1.0, 0.0, 100.0),          # backstepping (thesis sec. 4.3): K = this times I
    ("CTL_BS_KV2", TYPE_REAL32, 1.0, 0.0, 1000.0),       # backstepping: K's weight on the y_c velocity
)

#: Dead reckoning: the descent model's table (shared/estimator/descent_model.py,
#: whose constants are these defaults; roboray-sim identify --params-out fits them).
DESCENT = (
    ("DR_GLIDE_K0", TYPE_REAL32, -2.462, -10.0, 10.0),   # glide gain K with the wings flat (mean fold 0 deg)
    ("DR_GLIDE_K45", TYPE_REAL32, -1.069, -10.0, 10.0),  # K at a mean fold of 45 deg
    ("DR_GLIDE_K90", TYPE_REAL32, 0.323, -10.0, 10.0),   # K at a mean fold of 90 deg
    ("DR_DIFF_K", TYPE_REAL32, 0.422, 0.0, 2.0),         # glide per unit descent speed per 90 deg of differential
    ("DR_TAU", TYPE_REAL32, 0.0, 0.0, 5.0),              # s, lag of the horizontal velocity behind the model
)

PARAMS = LINK + STREAMS + FAILSAFE + MODES + CONTROL + DESCENT
