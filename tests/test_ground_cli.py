"""``roboray-ground`` end to end: the real CLI (a subprocess, pymavlink,
pyserial) against the board endpoint running on MicroPython behind a
pseudo-terminal."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest

from roboray.ground.cli import _finite
from roboray.ground.vehicle import PtyVehicle
from roboray.shared.mavlink.signing import key_from_passphrase

PASSPHRASE = "deep water"


def ground(*args: str, timeout: float = 60.0, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "roboray.ground.cli", *args],
                          capture_output=True, text=True, timeout=timeout, **kw)


@pytest.fixture(scope="module")
def vehicle():
    with PtyVehicle() as v:
        yield v


@pytest.fixture(scope="module")
def signed_vehicle():
    with PtyVehicle(key=key_from_passphrase(PASSPHRASE)) as v:
        yield v


def test_arm_mode_disarm(vehicle):
    r = ground("arm", "--master", vehicle.device)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "armed in PASSIVE"
    r = ground("mode", "velocity", "--master", vehicle.device)
    assert (r.returncode, r.stdout.strip()) == (0, "mode VELOCITY (GUIDED in MAVProxy and QGroundControl)")
    r = ground("mode", "target", "--master", vehicle.device)  # no target yet
    assert r.returncode == 1
    assert r.stderr.strip() == "roboray-ground: error: mode TARGET refused: no target set (failed)"
    r = ground("target", "2", "-1.5", "--master", vehicle.device, "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert (out["command"], out["result"], out["north_m"], out["east_m"]) == ("target", "accepted", 2.0, -1.5)
    r = ground("mode", "AUTO", "--master", vehicle.device, "--json")   # the name ground stations show
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["mode"] == "TARGET" and json.loads(r.stdout)["custom_mode"] == 3
    r = ground("status", "--master", vehicle.device, "--json", "--listen", "0.5")
    status = json.loads(r.stdout)
    assert status["mode"] == "TARGET" and status["armed"] is True and status["system"] == 1
    r = ground("disarm", "--master", vehicle.device + ",57600")
    assert (r.returncode, r.stdout.strip()) == (0, "disarmed in TARGET")   # the mode stays
    r = ground("status", "--master", vehicle.device, "--json", "--listen", "0.5")
    status = json.loads(r.stdout)
    assert status["mode"] == "TARGET" and status["armed"] is False
    r = ground("mode", "disarmed", "--master", vehicle.device)
    assert r.returncode == 2 and "DISARMED is no mode" in r.stderr and "use disarm" in r.stderr
    r = ground("mode", "passive", "--master", vehicle.device)
    assert r.returncode == 0, r.stderr


def test_status_and_watch_show_the_loop_load_and_the_worst_slot(vehicle):
    # the demo vehicle, held still, reports a load of 431 permille and a worst slot of 6800 us
    r = ground("status", "--master", vehicle.device, "--json")
    assert r.returncode == 0, r.stderr
    status = json.loads(r.stdout)
    assert (status["load_pct"], status["worst_slot_ms"]) == (43.1, 6.8)
    r = ground("status", "--master", vehicle.device)
    assert "loop      load 43.1%   worst slot 6.8 ms" in r.stdout.splitlines(), r.stdout
    r = ground("watch", "--master", vehicle.device, "--duration", "2.5")
    assert r.returncode == 0, r.stderr
    assert " load 43.1% worst slot 6.8 ms " in r.stdout.splitlines()[-1], r.stdout


def test_param_get_set_and_refusals(vehicle):
    r = ground("param", "get", "FS_GCS_TIMEOUT", "--master", vehicle.device)
    assert (r.returncode, r.stdout.strip()) == (0, "FS_GCS_TIMEOUT 5.0"), r.stderr
    r = ground("param", "set", "fs_gcs_timeout", "12.5", "--master", vehicle.device)
    assert (r.returncode, r.stdout.strip()) == (0, "FS_GCS_TIMEOUT 12.5 (was 5.0)"), r.stderr
    r = ground("param", "get", "FS_GCS_TIMEOUT", "--master", vehicle.device, "--json")
    assert json.loads(r.stdout) == {"FS_GCS_TIMEOUT": 12.5}
    r = ground("param", "set", "FS_GCS_TIMEOUT", "1000", "--master", vehicle.device)
    assert r.returncode == 1 and "out of range (value stays 12.5)" in r.stderr and len(r.stderr.splitlines()) == 1
    r = ground("param", "set", "FS_GCS_ENABLE", "abc", "--master", vehicle.device)
    assert r.returncode == 2 and "not a number" in r.stderr


def test_param_save_diff_load_round_trip(vehicle, tmp_path):
    f = tmp_path / "vehicle.parm"
    r = ground("param", "save", str(f), "--master", vehicle.device)
    assert r.returncode == 0, r.stderr
    lines = f.read_text().splitlines()
    assert any(line.split() == ["SYSID_THISMAV", "1"] for line in lines)
    # edit the file as a person would: comment, comma form, a new value
    text = "# tuned\n" + f.read_text().replace("FS_EKF_THRESH    0.8", "FS_EKF_THRESH,1.25")
    f.write_text(text)
    r = ground("param", "diff", str(f), "--master", vehicle.device, "--json")
    assert r.returncode == 1, r.stderr     # as diff(1): 1 when they differ
    assert json.loads(r.stdout) == [{"name": "FS_EKF_THRESH", "file": 1.25, "vehicle": pytest.approx(0.8)}]
    r = ground("param", "load", str(f), "--master", vehicle.device)
    assert r.returncode == 0 and "1 changed" in r.stdout, r.stdout + r.stderr
    r = ground("param", "diff", str(f), "--master", vehicle.device)
    assert (r.returncode, r.stdout.strip()) == (0, "no differences")


def test_param_files_round_trip_exactly(vehicle, tmp_path):
    # values whose float32s 7 significant digits cannot tell apart (the reload drift)
    first = tmp_path / "first.parm"
    r = ground("param", "save", str(first), "--master", vehicle.device)
    assert r.returncode == 0, r.stderr
    awkward = {"CTL_POS_P": "0.10000001", "BATT_LOW_VOLT": "6.6", "INS_POS1_Z": "-0.0029",
               "BARO1_GND_PRESS": "101325.01", "COMPASS_DEC": "0.123456789"}
    try:
        for name, value in awkward.items():
            r = ground("param", "set", name, value, "--master", vehicle.device)
            assert r.returncode == 0, r.stderr
        a, b = tmp_path / "a.parm", tmp_path / "b.parm"
        r = ground("param", "save", str(a), "--master", vehicle.device)
        assert r.returncode == 0, r.stderr
        held = json.loads(ground("param", "list", "--master", vehicle.device, "--json").stdout)
        line = {l.split()[0]: l.split()[1] for l in a.read_text().splitlines()}
        assert (line["CTL_POS_P"], line["BATT_LOW_VOLT"], line["INS_POS1_Z"]) == ("0.10000001", "6.6", "-0.0029")
        assert line["SYSID_THISMAV"] == "1" and line["SERVO1_MIN"] == "1000"   # integers without a point
        # back to the first file, then a: the vehicle holds what it held, bit for bit
        for path in (first, a):
            r = ground("param", "load", str(path), "--master", vehicle.device)
            assert r.returncode == 0, r.stdout + r.stderr
        assert json.loads(ground("param", "list", "--master", vehicle.device, "--json").stdout) == held
        r = ground("param", "diff", str(a), "--master", vehicle.device)
        assert (r.returncode, r.stdout.strip()) == (0, "no differences")
        r = ground("param", "save", str(b), "--master", vehicle.device)
        assert r.returncode == 0 and b.read_bytes() == a.read_bytes()
        # one float32 step apart: reported, and printed differently
        r = ground("param", "set", "CTL_POS_P", "0.1", "--master", vehicle.device)
        assert r.returncode == 0, r.stderr
        r = ground("param", "diff", str(a), "--master", vehicle.device)
        assert r.returncode == 1 and r.stdout.split() == ["CTL_POS_P", "file", "0.10000001", "vehicle", "0.1"]
    finally:
        ground("param", "load", str(first), "--master", vehicle.device)


def test_param_show_fetch_and_the_firmwares_whole_set(vehicle, tmp_path):
    from roboray.firmware.app import PARAMS

    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path))
    r = ground("param", "show", "--cached", env=env)
    assert r.returncode == 1 and "run param fetch first" in r.stderr
    # the demonstration vehicle has the firmware's parameters, every one
    r = ground("param", "fetch", "--master", vehicle.device, "--json", env=env)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["count"] == len(PARAMS)
    r = ground("param", "list", "--master", vehicle.device, "--json", env=env)
    assert sorted(json.loads(r.stdout)) == sorted(d[0] for d in PARAMS)
    # MAVProxy's wildcards, any case
    r = ground("param", "show", "fs_*_act", "--master", vehicle.device, env=env)
    assert r.returncode == 0, r.stderr
    assert [l.split()[0] for l in r.stdout.splitlines()] == [
        "FS_DEPTH_ACT", "FS_LOCKUP_ACT", "FS_LOOP_ACT", "FS_MAG_ACT", "FS_SENSOR_ACT"]
    r = ground("param", "show", "SERVO?_M[AI]?", "--cached", "--json", env=env)
    assert sorted(json.loads(r.stdout)) == sorted("SERVO%d_%s" % (k, e) for k in range(1, 5) for e in ("MIN", "MAX"))
    # -v: units, range, values, description
    r = ground("param", "show", "FS_GCS_[ET]*", "-v", "--cached", env=env)
    timeout = json.loads(ground("param", "show", "FS_GCS_TIMEOUT", "--cached", "--json", env=env).stdout)
    assert r.stdout.splitlines() == [   # (another test may have changed the timeout)
        "FS_GCS_ENABLE    1",
        "    What the vehicle does when no ground heartbeat arrived for FS_GCS_TIMEOUT s (after one was seen).",
        "    range 0 .. 3; 0: Off, 1: Warn, 2: Disarm, 3: FAILSAFE mode",
        "FS_GCS_TIMEOUT   %r s" % timeout["FS_GCS_TIMEOUT"],
        "    Time without a heartbeat from the ground station before the link-loss failsafe acts.",
        "    range 1.0 .. 120.0"]
    r = ground("param", "show", "SERIAL_BAUD", "-v", "--cached", "--json", env=env)
    row = json.loads(r.stdout)[0]
    assert (row["value"], row["range"], row["read_only"]) == (57600, [1200, 921600], True)
    r = ground("param", "show", "NO_SUCH*", "--cached", env=env)
    assert r.returncode == 1 and "no parameter matches NO_SUCH*" in r.stderr
    # fetch NAME: one value, read now
    r = ground("param", "fetch", "sr_status", "--master", vehicle.device, env=env)
    assert (r.returncode, r.stdout.strip()) == (0, "SR_STATUS 1.0"), r.stderr


def test_param_pdef_writes_the_documentation_without_a_vehicle(tmp_path):
    out = tmp_path / "apm.pdef.xml"
    r = ground("param", "pdef", str(out))
    assert r.returncode == 0, r.stderr
    text = out.read_text()
    from roboray.firmware.app import PARAMS
    assert text.count("<param ") == len(PARAMS) and 'name="RoboRay:CTL_SLEW_DPS"' in text
    assert '<field name="UnitText">degrees per second</field>' in text


def test_signed_vehicle_obeys_only_the_key(signed_vehicle, tmp_path):
    r = ground("arm", "--master", signed_vehicle.device, "--key", PASSPHRASE)
    assert (r.returncode, r.stdout.strip()) == (0, "armed in PASSIVE"), r.stderr
    keyfile = tmp_path / "key"
    keyfile.write_text(PASSPHRASE + "\n")
    r = ground("param", "set", "SR_SERVO", "5", "--master", signed_vehicle.device, "--key-file", str(keyfile))
    assert r.returncode == 0, r.stderr
    # unsigned: the vehicle ignores the command, we say why it may be
    r = ground("disarm", "--master", signed_vehicle.device, "--ack-timeout", "1")
    assert r.returncode == 1
    assert "no COMMAND_ACK for disarm" in r.stderr and "may require signing (--key)" in r.stderr
    r = ground("disarm", "--master", signed_vehicle.device, "--key", "wrong", "--timeout", "1")
    assert r.returncode == 1 and "signing key" in r.stderr
    r = ground("status", "--master", signed_vehicle.device, "--key", PASSPHRASE, "--json", "--listen", "0.5")
    assert json.loads(r.stdout)["armed"] is True  # still armed: the unsigned disarm did nothing


def test_attacks_on_the_demo_vehicle_then_the_legitimate_ground_across_a_restart():
    # the sequence of tests/test_signing_twin.py; the restart carries the signing record over
    import test_signing_twin as st

    with PtyVehicle(key=key_from_passphrase(st.PASSPHRASE)) as v:
        seen = st.attack(v.device, v.restart)
        assert v.restarts == 1 and seen["before"] == (2, 2) and seen["after_restart"] == (0, 0)


def test_signing_setup_then_only_that_key_then_signing_remove():
    with PtyVehicle() as v:
        d = v.device
        r = ground("signing", "setup", "--master", d)
        assert r.returncode == 2 and "usage: signing setup PASSPHRASE" in r.stderr
        r = ground("signing", "setup", "kelp forest", "--master", d)
        assert r.returncode == 0, r.stderr
        assert r.stdout.strip() == "signing key set on vehicle 1: it now obeys only frames signed with it (give it with --key)"
        assert r.stderr == ""
        # unsigned and wrong key: ignored; with the key: obeyed
        r = ground("arm", "--master", d, "--ack-timeout", "1")
        assert r.returncode == 1 and "may require signing (--key)" in r.stderr, r.stderr
        r = ground("arm", "--master", d, "--key", "kelp", "--timeout", "1")
        assert r.returncode == 1 and "same signing key" in r.stderr, r.stderr
        r = ground("signing", "setup", "mine now", "--master", d)   # without the current key: refused here
        assert r.returncode == 1 and "it has a key; give the current one with --key" in r.stderr, r.stderr
        r = ground("arm", "--master", d, "--key", "kelp forest")
        assert (r.returncode, r.stdout.strip()) == (0, "armed in PASSIVE"), r.stderr
        r = ground("signing", "remove", "--master", d, "--key", "kelp forest")
        assert r.returncode == 1 and "armed" in r.stderr and len(r.stderr.splitlines()) == 1, r.stderr
        r = ground("disarm", "--master", d, "--key", "kelp forest")
        assert r.returncode == 0, r.stderr
        # the key survives a restart; then removed (signed with it), which survives a restart too
        v.restart()
        r = ground("param", "get", "SYSID_THISMAV", "--master", d)
        assert r.returncode == 1 and "refuses ours without its key (--key)" in r.stderr, r.stderr
        r = ground("signing", "remove", "--master", d, "--key", "kelp forest", "--json")
        assert r.returncode == 0 and json.loads(r.stdout) == {"signing": "off", "system": 1, "changed": True}, r.stderr
        v.restart()
        r = ground("arm", "--master", d)
        assert (r.returncode, r.stdout.strip()) == (0, "armed in PASSIVE"), r.stderr
        r = ground("disarm", "--master", d)
        assert r.returncode == 0, r.stderr
        r = ground("signing", "remove", "--master", d)
        assert (r.returncode, r.stdout.strip()) == (0, "vehicle 1 has no signing key: nothing to remove")


def test_missing_port_busy_port_and_silent_port():
    r = ground("arm", "--master", "/dev/ttyNOPE0")
    assert r.returncode == 1
    assert r.stderr == ("roboray-ground: error: no such port /dev/ttyNOPE0: is the radio plugged in? "
                        "(roboray-ground ports lists them)\n")
    master, slave = os.openpty()  # a port with nothing behind it
    try:
        r = ground("status", "--master", os.ttyname(slave), "--timeout", "1")
    finally:
        os.close(master)
        os.close(slave)
    assert r.returncode == 1 and len(r.stderr.splitlines()) == 1
    assert "no heartbeat on /dev/pts/" in r.stderr and "at 57600 baud within 1 s" in r.stderr
    assert "baud rate (--baudrate)" in r.stderr
    r = ground("mode", "HOVER", "--master", "/dev/ttyNOPE0")
    assert r.returncode == 2 and "choose from PASSIVE, ATTITUDE, VELOCITY, TARGET, FAILSAFE" in r.stderr
    assert "MANUAL, STABILIZE, GUIDED, AUTO, SURFACE" in r.stderr


def test_log_record_dump_and_plot(vehicle, tmp_path):
    from pymavlink import mavutil

    log = tmp_path / "flight.tlog"
    r = ground("log", "record", str(log), "--master", vehicle.device, "--duration", "1.5", "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["frames"] > 20
    r = ground("tlog", "dump", str(log), "--json")
    ours = [json.loads(line) for line in r.stdout.splitlines()]
    # pymavlink reads the same file (MAVProxy's format) to the same messages
    os.environ["MAVLINK20"] = "1"
    mlog = mavutil.mavlink_connection(str(log), dialect="development")   # common.xml and CURRENT_MODE
    theirs = []
    while True:
        m = mlog.recv_msg()
        if m is None:
            break
        theirs.append((m._timestamp, m.to_dict()))
    assert len(ours) == len(theirs) > 20
    for a, (t, b) in zip(ours, theirs):
        assert a["crc_ok"] is True and a["timestamp"] == pytest.approx(t, abs=1e-5)
        # strict JSON: a NaN field (LOCAL_POSITION_NED_COV's unknown accelerations) is null, as in every --json
        assert {k: v for k, v in a.items() if k not in ("crc_ok", "timestamp")} == _finite(b)
    png = tmp_path / "flight.png"
    r = ground("log", "plot", str(log), "--out", str(png))
    assert r.returncode == 0, r.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_signed_tlog_dump_checks_signatures(signed_vehicle, tmp_path):
    log = tmp_path / "signed.tlog"
    r = ground("log", "record", str(log), "--master", signed_vehicle.device, "--key", PASSPHRASE,
               "--duration", "1")
    assert r.returncode == 0, r.stderr
    good = [json.loads(x) for x in ground("tlog", "dump", str(log), "--key", PASSPHRASE, "--json").stdout.splitlines()]
    assert good and all(m["signature_ok"] for m in good)
    bad = [json.loads(x) for x in ground("tlog", "dump", str(log), "--key", "wrong", "--json").stdout.splitlines()]
    assert len(bad) == len(good) and not any(m["signature_ok"] for m in bad) and all(m["crc_ok"] for m in bad)
    # damage one byte of one frame: it shows as crc_ok false, the rest still read
    data = bytearray(log.read_bytes())
    data[8 + 12] ^= 0xFF
    log.write_bytes(bytes(data))
    dumped = [json.loads(x) for x in ground("tlog", "dump", str(log), "--json").stdout.splitlines()]
    assert len(dumped) == len(good) and dumped[0]["crc_ok"] is False and all(m["crc_ok"] for m in dumped[1:])


def test_watch_prints_lines_when_piped_and_sees_the_link_drop_and_return(vehicle):
    import threading

    proc = subprocess.Popen([sys.executable, "-m", "roboray.ground.cli", "watch", "--master", vehicle.device,
                             "--duration", "30", "--lost-after", "1.2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines: list = []
    seen = threading.Event()

    def read() -> None:
        for line in proc.stdout:
            lines.append(line.rstrip("\n"))
            if "waiting" not in line:
                seen.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        # a loaded machine may take seconds to start the CLI: drop the link only once it has seen it
        assert seen.wait(20), lines
        time.sleep(1.0)
        vehicle.stop()      # the vehicle falls silent for well over the 1.2 s...
        time.sleep(3.5)
        vehicle.resume()    # ...and comes back
        time.sleep(2.5)
    finally:
        proc.terminate()
        err = proc.communicate(timeout=30)[1]
        reader.join(timeout=10)
    assert proc.returncode in (0, -15), err
    out = "\n".join(lines)
    assert len(lines) >= 3 and "\x1b" not in out  # plain lines (about one a second), no ANSI codes
    states = ["lost" if "LINK LOST" in line else "ok" for line in lines if "waiting" not in line]
    first_lost = states.index("lost")
    assert "ok" in states[:first_lost] and "ok" in states[first_lost:], out
    assert "disarmed" in out or "ARMED" in out


def _param(vehicle, name: str) -> float:
    r = ground("param", "get", name, "--master", vehicle.device, "--json")
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)[name]


def test_param_load_refuses_a_bad_file_whole_and_changes_nothing(vehicle, tmp_path):
    before = _param(vehicle, "SR_BATTERY")
    want = 0.25 if before != 0.25 else 0.5
    cases = {
        "binary.parm": (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", "binary file, not a parameter file"),
        "latin1.parm": ("SR_BATTERY %g\nCOMMENT \xe9t\xe9 1\n" % want).encode("latin-1"),
        "unknown.parm": ("SR_BATTERY %g\nNO_SUCH_PARAM 1\n" % want).encode(),
        "twice.parm": ("SR_BATTERY %g\nSR_BATTERY 0.1\n" % want).encode(),
        "range.parm": ("SR_BATTERY %g\nFS_GCS_TIMEOUT 1000\n" % want).encode(),
        "integer.parm": ("SR_BATTERY %g\nFS_GCS_ENABLE 1.5\n" % want).encode(),
        "garbage.parm": ("SR_BATTERY %g\nthis is not a line\n" % want).encode(),
    }
    why = {"latin1.parm": "is not UTF-8 text", "unknown.parm": "NO_SUCH_PARAM is not a parameter of the vehicle",
           "twice.parm": "SR_BATTERY is given twice (first on line 1)",
           "range.parm": "FS_GCS_TIMEOUT = 1000 is out of range [1, 120]",
           "integer.parm": "FS_GCS_ENABLE is an integer parameter",
           "garbage.parm": "expected NAME VALUE"}
    for name, case in cases.items():
        data, expected = case if isinstance(case, tuple) else (case, why[name])
        f = tmp_path / name
        f.write_bytes(data)
        r = ground("param", "load", str(f), "--master", vehicle.device)
        assert r.returncode == 1, (name, r.stdout, r.stderr)
        assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, (name, r.stderr)
        assert expected in r.stderr and "nothing was changed" in r.stderr, (name, r.stderr)
        assert _param(vehicle, "SR_BATTERY") == before, name   # the good line was not applied either
    # too large: refused from its size, before it is read
    big = tmp_path / "big.parm"
    with open(big, "wb") as fh:
        fh.truncate(50 * 1024 * 1024)
    r = ground("param", "load", str(big), "--master", vehicle.device)
    assert r.returncode == 1 and "52428800 bytes; a parameter file is at most 262144" in r.stderr, r.stderr
    # --partial: the good line is set, the bad one listed
    f = tmp_path / "unknown.parm"
    r = ground("param", "load", str(f), "--master", vehicle.device, "--partial", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["changed"] == ["SR_BATTERY"] and len(out["skipped"]) == 1 and "NO_SUCH_PARAM" in out["skipped"][0]
    assert _param(vehicle, "SR_BATTERY") == want
    r = ground("param", "set", "SR_BATTERY", "%g" % before, "--master", vehicle.device)
    assert r.returncode == 0, r.stderr


def test_tlog_dump_says_what_is_wrong_with_a_file(tmp_path):
    import struct

    from pymavlink.dialects.v20 import common as pm

    mav = pm.MAVLink(None, 1, 1)
    frames = [pm.MAVLink_attitude_message(i, 0.1 * i, 0.0, 0.0, 0.0, 0.0, 0.0).pack(mav) for i in range(5)]
    data = b"".join(struct.pack(">Q", 1_700_000_000_000_000 + 10_000 * i) + f for i, f in enumerate(frames))
    files = {"garbage.tlog": b"garbage! " * 40, "short.tlog": b"1234567", "cut.tlog": data[:-7], "ok.tlog": data}
    for name, content in files.items():
        (tmp_path / name).write_bytes(content)
    for name in ("garbage.tlog", "short.tlog"):
        r = ground("tlog", "dump", str(tmp_path / name))
        assert (r.returncode, r.stdout) == (1, ""), (name, r)
        assert "no tlog record in its" in r.stderr and "not a tlog" in r.stderr and r.stderr.count("\n") == 1
    r = ground("tlog", "dump", str(tmp_path / "cut.tlog"), "--json")
    # everything before the cut is printed, then the cut is said
    assert r.returncode == 1 and len(r.stdout.splitlines()) == 4
    assert "ends in a record cut short at byte 105 (a write interrupted?); 4 good record(s) read" in r.stderr
    r = ground("tlog", "dump", str(tmp_path / "ok.tlog"), "--types", "NOPE")
    assert r.returncode == 2 and "--types: no message type NOPE" in r.stderr and r.stdout == ""
    r = ground("tlog", "dump", str(tmp_path / "ok.tlog"), "--types", "heartbeat")
    assert r.returncode == 1 and "none of its 5 messages is HEARTBEAT" in r.stderr
    r = ground("tlog", "dump", str(tmp_path / "ok.tlog"), "--types", "attitude", "--json")
    assert r.returncode == 0 and len(r.stdout.splitlines()) == 5 and r.stderr == ""


def test_output_paths_are_refused_before_the_link_opens():
    # /dev/ttyNOPE0 would fail later: the path's error must come first
    for args in (("log", "record", "/missing/dir/x.tlog", "--master", "/dev/ttyNOPE0"),
                 ("param", "save", "/missing/dir/x.parm", "--master", "/dev/ttyNOPE0"),
                 ("log", "plot", "x.tlog", "--out", "/missing/dir/x.png")):
        r = ground(*args)
        assert r.returncode == 2 and "no folder /missing/dir to write it in" in r.stderr, (args, r.stderr)
        assert len(r.stderr.splitlines()) == 1


# ------------------------------------------------------- CLI conventions (issue 17)
def test_link_options_go_before_or_after_the_command_or_come_from_the_environment(vehicle):
    r = ground("--master", vehicle.device, "status", "--json", "--listen", "0.5")   # MAVProxy's order
    assert r.returncode == 0 and json.loads(r.stdout)["system"] == 1, r.stderr
    r = ground("--master", "/dev/ttyNOPE0", "--timeout", "2", "status", "--master", vehicle.device, "--listen", "0.5")
    assert r.returncode == 0, r.stderr   # given twice: the one after the command wins
    env = dict(os.environ, ROBORAY_MASTER=vehicle.device)
    r = ground("status", "--json", "--listen", "0.5", env=env)
    assert r.returncode == 0 and json.loads(r.stdout)["source"].startswith(vehicle.device), r.stderr
    r = ground("status", "--master", "/dev/ttyNOPE0", env=env)   # --master beats the environment
    assert r.returncode == 1 and "no such port /dev/ttyNOPE0" in r.stderr
    env = {k: v for k, v in os.environ.items() if k != "ROBORAY_MASTER"}
    for args in (("status",), ("log", "record", "x.tlog"), ("watch", "--duration", "1")):
        r = ground(*args, env=env)
        assert r.returncode == 2 and len(r.stderr.splitlines()) == 1, (args, r.stderr)
        assert "no link: give --master (before or after the command" in r.stderr and "ROBORAY_MASTER" in r.stderr


def test_target_says_what_it_understood_and_refuses_what_is_beyond_reach(vehicle):
    r = ground("target", "2", "-1", "--master", vehicle.device)
    assert r.returncode == 0, r.stderr   # the vehicle's CTL_DEPTH_M is 10 m: 4.85 m of reach
    assert r.stdout.strip() == ("target 2.00 m north, -1.00 m east (2.24 m away), bottom at 10.0 m (CTL_DEPTH_M): "
                                "reach 4.85 m")
    r = ground("target", "-1.5", "-.5", "--down", "4", "--master", vehicle.device, "--json")
    out = json.loads(r.stdout)
    assert (out["north_m"], out["east_m"], out["bottom_m"], out["bottom_from"]) == (-1.5, -0.5, 4.0, "--down")
    # beyond the reach from the vehicle's bottom depth: refused after asking it, nothing sent
    r = ground("target", "6", "0", "--master", vehicle.device)
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1, r.stderr
    assert "target 6.00 m north, 0.00 m east is 6.00 m away, beyond the reach" in r.stderr
    assert "bottom at 10.0 m (the vehicle's CTL_DEPTH_M: give --down): 4.85 m" in r.stderr
    # centimetres typed as metres: refused before the link opens (the port does not exist)
    r = ground("target", "200", "100", "--master", "/dev/ttyNOPE0")
    assert r.returncode == 2 and "223.61 m away, beyond the reach" in r.stderr and "give --down" in r.stderr
    r = ground("target", "2", "1", "--down", "1", "--master", "/dev/ttyNOPE0")
    assert r.returncode == 2 and "bottom at 1.0 m (--down): 0.49 m" in r.stderr
    r = ground("target", "2", "1", "--down", "-10", "--master", "/dev/ttyNOPE0")
    assert r.returncode == 2 and "argument --down: '-10' must be greater than 0" in r.stderr


def test_master_auto_takes_the_one_sik_radio():
    from serial.tools.list_ports_common import ListPortInfo

    from roboray.ground import radios

    def port(device, vid, pid):
        p = ListPortInfo(device, skip_link_detection=True)
        p.vid, p.pid, p.product = vid, pid, "radio"
        return p

    pico, ftdi, cp210x, other = (port("/dev/ttyACM0", 0x2E8A, 0x0005), port("/dev/ttyUSB1", 0x0403, 0x6015),
                                 port("/dev/ttyUSB0", 0x10C4, 0xEA60), port("/dev/ttyUSB2", 0x1A86, 0x7523))
    assert radios.pick("/dev/ttyS0", []) == "/dev/ttyS0"
    assert radios.pick("auto", [pico, ftdi, other]) == "/dev/ttyUSB1"
    assert radios.pick("auto", [cp210x, pico]) == "/dev/ttyUSB0"
    with pytest.raises(radios.NoRadioFound, match="no radio found: .*0403:6015, 10c4:ea60"):
        radios.pick("auto", [pico, other])
    with pytest.raises(radios.NoRadioFound, match="2 radios found, choose one with --master: /dev/ttyUSB0 "):
        radios.pick("auto", [ftdi, cp210x])


def test_bad_link_values_are_usage_errors():
    for args, words in ((("status", "--timeout", "-1"), "argument --timeout: '-1' must be greater than 0"),
                        (("--baudrate", "fast", "status"), "'fast' is not a baud rate"),
                        (("arm", "--source-system", "256"), "'256' is not a MAVLink system id (1 to 255)"),
                        (("arm", "--ack-timeout", "0"), "argument --ack-timeout: '0' must be greater than 0")):
        r = ground(*args, "--master", "/dev/ttyNOPE0")
        assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and words in r.stderr, (args, r.stderr)


def test_reboot_is_refused_armed_and_sent_disarmed(vehicle):
    assert ground("arm", "--master", vehicle.device).returncode == 0
    r = ground("reboot", "--master", vehicle.device)
    assert r.returncode == 1
    assert r.stderr.strip() == "roboray-ground: error: reboot refused: disarm first (failed)"
    assert ground("disarm", "--master", vehicle.device).returncode == 0
    before = vehicle.reboots
    r = ground("reboot", "--master", vehicle.device, "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == {"command": "reboot", "result": "accepted", "back_after_s": None}
    end = time.monotonic() + 5.0   # the vehicle's loop takes the request after its ACK left
    while vehicle.reboots == before and time.monotonic() < end:
        time.sleep(0.05)
    assert vehicle.reboots == before + 1
