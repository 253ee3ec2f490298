"""What the vehicle reports: a state object the firmware fills, the endpoint sends.

Every quantity lives in a buffer made once; the firmware writes into them
(``t.q[0] = w``), the endpoint reads them when a stream is due. SI units and
radians unless the name says otherwise; NED frame as MAVLink uses.
"""

from array import array


class Telemetry:
    """Vehicle state for the telemetry streams.

    Attributes
    ----------
    q : array('f', 4)
        Attitude quaternion [w, x, y, z], body to NED.
    rates : array('f', 3)
        Body rates, rad/s.
    pos_ned, vel_ned : array('f', 3)
        Position (m, from the release point) and velocity (m/s), NED.
    var_ned : array('f', 4)
        Horizontal variances: north, east (m^2), north and east velocity
        ((m/s)^2); they grow while the position is dead-reckoned.
    var_dz : array('f', 2)
        Depth (m^2) and vertical speed ((m/s)^2) variances.
    target_ned : array('f', 3)
        Current target position (m, NED); ``has_target`` says whether it is set.
    env : array('f', 3)
        [depth_m, pressure_pa, temperature_c] from the depth sensor.
    imu : array('f', 9)
        Accelerometer (m/s^2), gyroscope (rad/s), magnetometer (gauss), body frame.
    servo_deg : array('f', 4)
        Wing angles, degrees, wings 1..4.
    servo_us : array('H', 4)
        Servo pulses, microseconds.
    battery : array('f', 3)
        [voltage_v, current_a, remaining_frac]; remaining < 0 means unknown.
    failsafe_flags : int
        Bit set of active failsafes (firmware's numbering), sent in
        SYS_STATUS ``errors_count1``.
    sensors_present, sensors_enabled, sensors_health : int
        MAV_SYS_STATUS_SENSOR bit sets.
    load_permille : int
        Main-loop load, 0..1000.
    """

    def __init__(self):
        self.q = array("f", [1.0, 0.0, 0.0, 0.0])
        self.rates = array("f", [0.0, 0.0, 0.0])
        self.pos_ned = array("f", [0.0, 0.0, 0.0])
        self.vel_ned = array("f", [0.0, 0.0, 0.0])
        self.var_ned = array("f", [0.0] * 4)
        self.var_dz = array("f", [0.0, 0.0])
        self.target_ned = array("f", [0.0, 0.0, 0.0])
        self.has_target = False
        self.env = array("f", [0.0, 101325.0, 20.0])
        self.imu = array("f", [0.0] * 9)
        self.servo_deg = array("f", [0.0, 0.0, 0.0, 0.0])
        self.servo_us = array("H", [1500, 1500, 1500, 1500])
        self.battery = array("f", [0.0, 0.0, -1.0])
        self.failsafe_flags = 0
        self.sensors_present = 0
        self.sensors_enabled = 0
        self.sensors_health = 0
        self.load_permille = 0
