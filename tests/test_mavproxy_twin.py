"""MAVProxy itself (PyPI's, headless, its standard modules) against the twin's radio.

The firmware flies in the twin on MicroPython, its 57,600-baud radio UART
behind a pseudo-terminal; ``mavproxy.py`` connects to it as to a SiK radio
and is driven through its stdin as a user types: it must show the
vehicle's modes by names that say what they do and switch to them by name,
``arm throttle``, fetch every parameter, list the landing target with
``wp list``, never report a fence breach, and (issue 18) list and download
the on-board log once the vehicle is disarmed.
"""

from __future__ import annotations

import threading

from pymavlink import DFReader

from roboray.firmware.app import PARAMS
from roboray.sim.twin.runner import Options, Twin
from test_mission_vehicle import MAVProxy


def _expect(mp: MAVProxy, text: str, timeout: float) -> str:
    line = mp.expect(lambda s: text in s, timeout)
    if line is None:
        raise AssertionError("MAVProxy never printed %r within %g s; it printed:\n%s"
                             % (text, timeout, "\n".join(mp.seen[-40:])))
    return line


def _wait(mp: MAVProxy, seconds: float) -> None:
    mp.expect(lambda s: False, seconds)     # reads (and keeps) what it prints meanwhile


def test_mavproxy_modes_arming_parameters_mission_and_the_on_board_log(tmp_path):
    report: dict = {}
    done = threading.Event()

    def on_radio(radio):
        def session():
            mp = MAVProxy(radio.device, tmp_path)
            try:
                _expect(mp, "online system 1", 40)
                mp.send("param fetch")
                report["params"] = _expect(mp, "Received %d parameters" % len(PARAMS), 30)
                mp.send("mode")
                report["modes"] = _expect(mp, "Available modes", 10)
                mp.send("wp list")
                report["wp"] = _expect(mp, "Saved", 15)
                mp.send("mode STABILIZE")
                report["mode_set"] = _expect(mp, "Mode STABILIZE", 10)
                mp.send("arm throttle")     # (the scripted operator armed already: ArduPilot accepts it again)
                report["arm"] = _expect(mp, "COMPONENT_ARM_DISARM: ACCEPTED", 10)
                mp.send("mode MANUAL")
                _expect(mp, "Mode MANUAL", 10)
                _wait(mp, 2.5)                     # 5 s on the bottom in PASSIVE, logging to RAM
                mp.send("disarm force")
                _expect(mp, "DISARMED", 10)
                _wait(mp, 3.0)                     # 6 s disarmed: the dive goes to flash
                mp.send("log list")
                report["log_list"] = _expect(mp, "numLogs", 15)
                mp.send("log download latest dive.BIN")
                report["log_download"] = _expect(mp, "Finished downloading", 120)
            except Exception as exc:   # reported by the assertions below
                report["error"] = str(exc)
            finally:
                mp.close()
                report["printed"] = "\n".join(mp.seen)
                done.set()

        threading.Thread(target=session, daemon=True).start()

    # bottom-rest: the scripted operator arms, the vehicle sinks to the
    # bottom 1 m down and rests there for as long as the session takes (the
    # session ends the run). Twice real time: MAVProxy's own waits are in
    # wall time, the radio's 57,600 baud and the vehicle's in simulated time
    Twin(Options(scenario="bottom-rest", radio="pty", speedup=2.0, duration=200.0), on_radio=on_radio,
         on_frame=lambda twin: done.is_set() and twin.stop()).run()
    assert done.wait(60)
    assert "error" not in report, report["error"]
    printed = report["printed"]
    # names that say what the vehicle does, every RoboRay mode reachable by one
    for name in ("STABILIZE", "MANUAL", "GUIDED", "AUTO", "SURFACE"):
        assert name in report["modes"], report["modes"]
    assert "Unknown mode" not in printed and "Mode(" not in printed
    assert "fence breach" not in printed.lower()
    assert "Received %d parameters" % len(PARAMS) in report["params"]
    # the parameter fetch by FTP is refused with a NAK at once (shared/mavlink/ftp.py), not timed out
    assert "FTP: request timed out" not in printed
    # wp list: home and the target (none set here: home alone, as ArduPilot's empty mission)
    assert "waypoints" in printed
    # the log: listed and downloaded whole, and pymavlink reads it
    path = tmp_path / "dive.BIN"
    assert path.exists() and path.stat().st_size > 10_000
    log = DFReader.DFReader_binary(str(path))
    kinds = set()
    while (m := log.recv_match()) is not None:
        kinds.add(m.get_type())
    assert {"ATT", "IMU", "BARO", "EST", "PARM", "MODE", "EV"} <= kinds
