"""The telemetry streams' rates as a ground station sets them.

Six streams, each with its ``SR_*`` rate parameter (Hz, 0: off), as
ArduPilot's ``SRn_*``. A ground station sets them with REQUEST_DATA_STREAM
(ArduPilot's stream groups, no answer), MAV_CMD_SET_MESSAGE_INTERVAL (the
stream a message is in; ``commands.py`` answers it) or PARAM_SET. The
endpoint (``endpoint.py``) sends the streams' frames at those rates.
"""

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

from roboray.shared.mavlink import messages as msg

# Stream groups and the parameter holding each one's rate
STREAM_PARAMS = ("SR_ATTITUDE", "SR_POSITION", "SR_SENSORS", "SR_SERVO", "SR_BATTERY", "SR_STATUS")
S_ATTITUDE = const(0)
S_POSITION = const(1)
S_SENSORS = const(2)
S_SERVO = const(3)
S_BATTERY = const(4)
S_STATUS = const(5)
N_STREAMS = const(6)

# REQUEST_DATA_STREAM: ArduPilot's stream groups (MAV_DATA_STREAM id) -> our
# stream number + 1 (0: none here). RAW_SENSORS: sensors; EXTENDED_STATUS:
# status; RC_CHANNELS: servo; POSITION: position; EXTRA1: attitude; EXTRA3: battery.
_DATA_STREAMS = b"\x00\x03\x06\x04\x00\x00\x02\x00\x00\x00\x01\x00\x05"


def stream_of(msgid):
    """The stream message ``msgid`` goes out in, or -1."""
    if msgid == msg.MSG_ATTITUDE or msgid == msg.MSG_ATTITUDE_QUATERNION:
        return S_ATTITUDE
    if msgid == msg.MSG_LOCAL_POSITION_NED or msgid == msg.MSG_POSITION_TARGET_LOCAL_NED \
            or msgid == msg.MSG_LOCAL_POSITION_NED_COV:
        return S_POSITION
    if msgid == msg.MSG_SCALED_PRESSURE or msgid == msg.MSG_SCALED_IMU:
        return S_SENSORS
    if msgid == msg.MSG_SERVO_OUTPUT_RAW:
        return S_SERVO
    if msgid == msg.MSG_BATTERY_STATUS:
        return S_BATTERY
    if msgid == msg.MSG_SYS_STATUS or msgid == msg.MSG_SYSTEM_TIME or msgid == msg.MSG_MISSION_CURRENT:
        return S_STATUS
    return -1


def handle_request_data_stream(ep, p):
    """REQUEST_DATA_STREAM: ArduPilot's stream groups onto our ``SR_*`` rates
    (no answer: the protocol has none). Its fields are integers: a rate of
    0-65535 Hz is held to the parameter's limits."""
    pl = p.payload
    if not ep._for_us(pl[2], pl[3]):
        return
    stream_id = pl[4]
    start_stop = pl[5]
    if start_stop > 1:
        return
    hz = float(pl[0] | (pl[1] << 8)) if start_stop else 0.0
    if stream_id == msg.MAV_DATA_STREAM_ALL:
        for k in range(N_STREAMS):
            set_rate(ep, k, hz)
        return
    k = _DATA_STREAMS[stream_id] - 1 if stream_id < len(_DATA_STREAMS) else -1
    if k >= 0:
        set_rate(ep, k, hz)


def set_rate(ep, k, hz):
    """Stream ``k`` at ``hz`` (finite: the callers check), or its parameter's
    limit when beyond it."""
    params = ep.params
    i = ep._p_rates[k]
    if params.set(i, hz):
        hi = params.maximum(i)
        params.set(i, hi if hz > hi else params.minimum(i))
