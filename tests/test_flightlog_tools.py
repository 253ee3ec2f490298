"""pymavlink's own log tools on the vehicle's flight log (issue 26 item 5):
they name RoboRay's modes, not ArduPlane's for the same numbers."""

from __future__ import annotations

import os
import subprocess
import sys

from pymavlink import DFReader

from roboray.firmware.flightlog import files as F
from roboray.firmware.flightlog import logger as L
from roboray.firmware.param_store import Files
from roboray.shared import modes, param_defs
from roboray.shared.mavlink.telemetry import Telemetry
from roboray.shared.params import ParamTable

STEP_US = 20_000


def _dive(tmp_path):
    """A dive logged by the firmware's logger: PASSIVE on deck, armed, TARGET,
    resting, disarmed. The logger is handed HEARTBEAT's custom_mode, as the
    application hands it."""
    params = ParamTable(param_defs.PARAMS + L.PARAMS)
    t = Telemetry()
    us = [0]
    log = L.FlightLog(params, t, F.LogFiles(Files(), root=str(tmp_path / "logs")), lambda: us[0],
                      lambda a, b: a - b, expect_delay=lambda ms: None)

    def run(seconds, armed, mode, descent=0.0, depth=1.0):
        for _ in range(int(seconds * 1e6 / STEP_US)):
            us[0] += STEP_US
            t.vel_ned[2] = descent
            t.q[0] = 1.0
            t.env[0] = depth
            log.step(armed, modes.CUSTOM[mode])

    run(3.0, False, modes.PASSIVE)
    run(1.0, True, modes.PASSIVE)
    run(10.0, True, modes.TARGET, descent=0.3)
    run(6.0, True, modes.TARGET)
    run(3.0, False, modes.PASSIVE)
    return tmp_path / "logs" / "00000001.BIN"


def test_dfreader_and_mavflightmodes_name_our_modes(tmp_path):
    path = _dive(tmp_path)
    log = DFReader.DFReader_binary(str(path))
    seen = []
    while (m := log.recv_match(type="MODE")) is not None:
        seen.append((log.flightmode, m.ModeNum))
    assert seen == [("PASSIVE", modes.CUSTOM[modes.PASSIVE]), ("TARGET", modes.CUSTOM[modes.TARGET]),
                    ("PASSIVE", modes.CUSTOM[modes.PASSIVE])]
    tool = os.path.join(os.path.dirname(sys.executable), "mavflightmodes.py")
    out = subprocess.run([sys.executable, tool, str(path)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    said = [ln.split("MAV.flightmode=")[1].split()[0] for ln in out.stdout.splitlines() if "MAV.flightmode=" in ln]
    assert said == ["PASSIVE", "TARGET", "PASSIVE"], out.stdout
    for plane in ("QLOITER", "TRAINING", "MANUAL", "AUTO"):
        assert plane not in out.stdout
