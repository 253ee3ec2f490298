"""The parameter protocol: PARAM_REQUEST_LIST (streamed a few a cycle by the
endpoint), PARAM_REQUEST_READ (by index or name), PARAM_SET.

PARAM_SET's value must be finite (NaN and the infinities are refused here,
before the ``ParamTable``); its type and range are the table's to enforce.
A refused set is answered as ArduPilot's: the PARAM_VALUE echo carries the
value in force (unchanged), and a STATUSTEXT says why.
"""

import struct

from roboray.shared.mavlink import messages as msg
from roboray.shared.params import ERRORS


def handle_request_list(ep, p):
    pl = p.payload
    if ep._for_us(pl[0], pl[1]):
        ep._param_next = 0


def handle_request_read(ep, p):
    pl = p.payload
    if ep._for_us(pl[2], pl[3]):
        index = pl[0] | (pl[1] << 8)
        if index >= 0x8000:
            index = ep.params.find(pl, 4, 16)
        if 0 <= index < ep.params.count():
            ep._answer_param(index)


def handle_set(ep, p):
    pl = p.payload
    if not ep._for_us(pl[4], pl[5]):
        return
    params = ep.params
    i = params.find(pl, 6, 16)
    if i < 0:
        ep.send_text(msg.MAV_SEVERITY_WARNING, "PARAM_SET: unknown parameter")
        return
    value = struct.unpack_from("<f", pl, 0)[0]
    if value - value != 0.0:        # NaN or infinite
        ep.send_text(msg.MAV_SEVERITY_WARNING, "%s: %s is no value" % (params.name(i), value))
    else:
        err = params.set(i, value)
        if err:
            ep.send_text(msg.MAV_SEVERITY_WARNING, "%s: %s" % (params.name(i), param_error(err)))
    ep._answer_param(i)


def param_error(err):
    return ERRORS[err] if 0 <= err < len(ERRORS) else "error %d" % err
