"""The twin's radio through water (issue 27): frames lost by the antenna's
depth and back as it nears the surface, SiK RADIO_STATUS read by pymavlink
on the twin's pseudo-terminal, the sil report's link figures, campaign
flights whose fixes cross the link."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time

import pytest

from roboray.sim.radio import link as link_mod
from roboray.sim.twin import water_link
from roboray.sim.twin.ground import Ground
from roboray.sim.twin.runner import Options, Twin


def _frames(ground_bytes: bytes) -> list:
    g = Ground([], heartbeats=False)
    return g.receive(ground_bytes)


def test_frames_are_lost_by_depth_and_come_back_near_the_surface():
    lk = link_mod.make("hc12-433", "fresh")
    wl = water_link.WaterLink(lk, seed=3)
    data = b"\xfd" + bytes(30)        # a frame's worth of bytes each way, each frame time
    t, dt = 0.0, 0.02
    crossed = []
    # down at 0.25 m/s to twice the reach, then up again
    depths = [0.25 * k * dt for k in range(int(2 * lk.reach_m / (0.25 * dt)))]
    for d in depths + depths[::-1]:
        wl.step(t, d, dt)
        crossed.append((d, wl.crosses(data, 0), wl.crosses(data, 1)))
        t += dt
    shallow = [c for c in crossed if c[0] < lk.reach_m - 1.0]
    deep = [c for c in crossed if c[0] > lk.reach_m + 1.0]
    assert shallow and deep
    assert all(up and down for _, up, down in shallow)
    assert not any(up or down for _, up, down in deep)
    kinds = [e["event"] for e in wl.events]
    assert kinds[0] == "lost" and kinds[-1] == "regained"
    lost, back = wl.events[0], wl.events[-1]
    assert abs(lost["depth_m"] - lk.reach_m) < 1.0 and abs(back["depth_m"] - lk.reach_m) < 1.0
    r = wl.report(t)
    assert r["link_lost_depth_m"] == lost["depth_m"]
    assert r["time_without_link_s"] > 0 and r["frames_lost_to_ground"] > 0 and r["frames_lost_to_vehicle"] > 0
    # deterministic for a seed
    again = water_link.WaterLink(lk, seed=3)
    t = 0.0
    for d in depths + depths[::-1]:
        again.step(t, d, dt)
        t += dt
    assert again.events == wl.events


def test_sik_radio_status_is_a_real_mavlink_frame_from_the_radio():
    wl = water_link.WaterLink(link_mod.make("sik-433", "fresh"), seed=0)
    wl.step(1.0, 0.5, 0.02)
    to_ground, to_vehicle = wl.statuses()
    for data in (to_ground, to_vehicle):
        (m,) = _frames(data)
        assert m.get_type() == "RADIO_STATUS"
        assert (m.get_srcSystem(), m.get_srcComponent()) == (water_link.SIK_SYSID, water_link.SIK_COMPID)
        level = wl.channel.level_db + wl.link.radio.sensitivity_dbm
        assert m.rssi == water_link.sik_units(level) and m.remrssi == m.rssi
        assert m.noise < m.rssi
    assert wl.statuses() == (b"", b"")          # once a second
    # below the reach: each radio counts what it failed to receive
    deep = water_link.WaterLink(link_mod.make("sik-433", "sea"), seed=0)
    deep.step(1.0, 1.0, 0.02)
    assert not deep.crosses(b"\xfd" + bytes(20), 0) and not deep.crosses(b"\xfd" + bytes(20), 0)
    assert not deep.crosses(b"\xfd" + bytes(20), 1)
    to_ground, to_vehicle = (_frames(d)[0] for d in deep.statuses())
    assert (to_ground.rxerrors, to_vehicle.rxerrors) == (2, 1)
    assert to_ground.remrssi == 0 and to_ground.rssi == water_link.sik_units(deep.link.radio.noise_dbm)
    # the HC-12 is transparent: nothing of its own
    hc = water_link.WaterLink(link_mod.make("hc12-433", "fresh"), seed=0)
    hc.step(1.0, 0.5, 0.02)
    assert hc.statuses() == (b"", b"")


@pytest.fixture(scope="module")
def sea_and_fresh():
    out = {}
    for water in ("sea", "fresh"):
        o = Options(scenario="target-landing", interpreter="cpython", water=water, radio_model="hc12-433",
                    depth=4.0, target=(0.8, 0.0), seed=1)
        out[water] = Twin(o).run()
    return out


def test_sil_in_sea_water_loses_the_link_just_under_the_surface_and_still_lands(sea_and_fresh):
    sea, fresh = sea_and_fresh["sea"], sea_and_fresh["fresh"]
    assert sea["landed"] and fresh["landed"]
    assert sea["link_lost_depth_m"] is not None and sea["link_lost_depth_m"] < 0.5
    assert sea["time_without_link_s"] > 5.0
    # fresh water reaches 5.6 m: a 4 m pool never loses it
    assert fresh["link_lost_depth_m"] is None and fresh["time_without_link_s"] == 0.0
    assert sea["fixes_used"] < fresh["fixes_used"] <= fresh["fixes_sent"]
    assert sea["frames_lost_to_ground"] > 0 and fresh["frames_lost_to_ground"] == 0
    assert sea["landing_error_m"] < 0.5


def test_sil_radio_status_on_the_pty_for_pymavlink(tmp_path):
    from pymavlink import mavutil

    proc = subprocess.Popen([sys.executable, "-m", "roboray.sim.cli", "sil", "--interpreter", "cpython",
                             "--radio", "pty", "--radio-model", "sik-433", "--duration", "4", "--linger", "--json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    err: list = []

    def read() -> None:
        for line in proc.stderr:
            err.append(line)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        end = time.monotonic() + 120
        device = None
        while device is None and time.monotonic() < end:
            device = next((ln.split()[1] for ln in list(err) if ln.startswith("radio: /dev/pts/")), None)
            time.sleep(0.1)
        assert device is not None, err
        os.environ.setdefault("MAVLINK20", "1")
        conn = mavutil.mavlink_connection(device, baud=57600, dialect="common")
        try:
            m = conn.recv_match(type="RADIO_STATUS", blocking=True, timeout=60)
        finally:
            conn.close()
        assert m is not None, "no RADIO_STATUS on %s" % device
        assert (m.get_srcSystem(), m.get_srcComponent()) == (51, 68)
        # held at the surface: the antenna in the air, ~96 dB over -117 dBm
        assert m.rssi > 150 and m.remrssi > 150 and m.noise < 60
        # Ctrl-C once the scenario is over: a lingering run's normal end
        while not any("the scenario is over" in ln for ln in list(err)) and time.monotonic() < end:
            time.sleep(0.1)
    finally:
        os.killpg(proc.pid, signal.SIGINT)
        out, _ = proc.communicate(timeout=120)
    reader.join(timeout=10)
    assert proc.returncode == 0, "".join(err)
    report = json.loads(out)
    assert report["radio_model"] == "sik-433" and report["link_lost_depth_m"] is None


def test_sil_text_says_where_the_link_went(capsys):
    from roboray.sim.cli import main

    assert main(["sil", "--scenario", "target-landing", "--interpreter", "cpython", "--water", "sea", "--depth", "2",
                 "--target", "0.5,0"]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.startswith("radio link"))
    assert line.startswith("radio link (hc12-433, 4.5 S/m water, reach 0.11 m): lost below 0.1")
    assert "fixes used" in line and "s without it" in line


def test_a_signed_link_takes_the_radios_unsigned_radio_status():
    # the radio's own RADIO_STATUS is never signed: the ground accepts it, as
    # MAVProxy and ArduPilot do, and counts no bad frame
    t = Twin(Options(scenario="passive-drop", interpreter="cpython", radio_model="sik-433", key="secret",
                     duration=4))
    r = t.run()
    assert r["bad_frames_from_vehicle"] == 0
    assert len(t.ground.seen.radio_status) >= 3
    assert all(rssi > 150 for _, rssi, _, _, _ in t.ground.seen.radio_status)
