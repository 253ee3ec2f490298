"""The parameter list over the twin's 57,600-baud radio, as a ground station gets it.

The firmware on MicroPython, its radio UART emulated at 57,600 baud
(``sim/twin/board/machine.py``) behind a pseudo-terminal (``--radio pty``);
pymavlink on the other end asks for the list once and never again: every
value arrives (the endpoint paces the list by what the line carries,
``shared/mavlink/endpoint.py``), and a PARAM_REQUEST_READ sent while the
list streams is answered within it.
"""

from __future__ import annotations

import threading
import time

from pymavlink import mavutil

from roboray.firmware.app import PARAMS
from roboray.sim.twin.runner import Options, Twin


def test_the_whole_list_arrives_at_57600_baud_without_a_re_request():
    got: dict = {}
    done = threading.Event()

    def on_radio(radio):
        def talk():
            m = mavutil.mavlink_connection(radio.device, baud=57600, source_system=255)
            try:
                hb = m.wait_heartbeat(timeout=30)
                sysid, compid = hb.get_srcSystem(), hb.get_srcComponent()
                time.sleep(0.5)     # the streams running
                m.mav.param_request_list_send(sysid, compid)
                values: dict = {}
                times: dict = {}    # PARAM_VALUEs of each name: the list's one, and the read's
                asked = False
                t0 = time.monotonic()
                while time.monotonic() - t0 < 8 and (len(values) < len(PARAMS) or times.get("CTL_SLEW_DPS", 0) < 2):
                    msg = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=1.0)
                    if msg is None:
                        continue
                    times[msg.param_id] = times.get(msg.param_id, 0) + 1
                    values[msg.param_index] = (msg.param_id, msg.param_count, msg.param_value)
                    if len(values) == 20 and not asked:
                        m.mav.param_request_read_send(sysid, compid, b"CTL_SLEW_DPS", -1)
                        asked = True
                got.update(values=values, times=times, seconds=time.monotonic() - t0)
            except Exception as exc:  # reported by the assertions below
                got["error"] = repr(exc)
            finally:
                m.close()
                done.set()

        threading.Thread(target=talk, daemon=True).start()

    Twin(Options(scenario="passive-drop", radio="pty", speedup=1.0, duration=16.0), on_radio=on_radio,
         on_frame=lambda twin: done.is_set() and twin.stop()).run()
    assert done.wait(30)
    assert "error" not in got, got["error"]
    names = [d[0] for d in PARAMS]
    values = got["values"]
    assert sorted(values) == list(range(len(names))), "missing: %s" % sorted(set(range(len(names))) - set(values))
    assert [values[i][0] for i in range(len(names))] == names
    assert {v[1] for v in values.values()} == {len(PARAMS)}
    # each value once from the list; CTL_SLEW_DPS a second time, the read's answer in the middle of it
    assert got["times"] == dict({n: 1 for n in names}, CTL_SLEW_DPS=2)
    assert values[names.index("CTL_SLEW_DPS")][2] == 60.0
    assert got["seconds"] < 3.0         # ~3 kB of PARAM_VALUE beside the streams: well under 3 s at 5.76 kB/s
