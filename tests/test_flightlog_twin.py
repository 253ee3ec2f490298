"""The flight log in the twin: a dive's log on the board's flash, downloaded over the
57,600-baud radio with ``ground/logs.py`` (as ``roboray-ground log download``), cut off
and resumed, byte for byte what the board keeps, and read by pymavlink's DFReader."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

from pymavlink import DFReader

from roboray.ground.link import Link
from roboray.ground.logs import download, erase_logs, list_logs
from roboray.sim.twin.ground import Action
from roboray.sim.twin.runner import Options, Twin


class Cut(Exception):
    """The download stopped by hand (a Ctrl-C, a lost link) after some bytes."""


def _stop_after(done: threading.Event, seconds: float):
    """The twin's ``on_frame``: the run ends ``seconds`` of simulated time
    after the ground is done (the board prepares the next dive's log on
    flash within a second of an erase: nothing the ground can list)."""
    at: list = []

    def on_frame(twin) -> None:
        if done.is_set():
            if not at:
                at.append(twin.world.t + seconds)
            elif twin.world.t >= at[0]:
                twin.stop()

    return on_frame


def test_a_dive_log_is_downloaded_over_the_radio_resumed_after_a_cut_and_erased(tmp_path):
    got: dict = {}
    done = threading.Event()
    out = tmp_path / "dive.BIN"

    def on_radio(radio):
        def ground():
            link = None
            try:
                link = Link(radio.device, 57600)
                link.wait_heartbeat(timeout=30)
                # armed: refused, with a reason
                while not (link.vehicle_heartbeat.base_mode & 128):
                    link.wait_heartbeat(timeout=5)
                link.mav.log_request_list_send(link.target_system, link.target_component, 0, 0xFFFF)
                got["armed_text"] = link.wait(lambda m: m.get_type() == "STATUSTEXT", 5).text
                # the operator disarms on the bottom (below): then the dive is on flash
                while link.vehicle_heartbeat.base_mode & 128:
                    link.wait_heartbeat(timeout=5)
                time.sleep(3.0)
                entries = list_logs(link)
                got["entries"] = [e.as_dict() for e in entries]
                entry = entries[0]

                def cut_after(received, size):
                    if received > size // 3:
                        raise Cut()

                try:
                    download(link, entry, str(out), progress=cut_after)
                except Cut:
                    got["part"] = (tmp_path / "dive.BIN.part").exists()
                got["result"] = download(link, entry, str(out))
                got["whole"] = download(link, entry, str(tmp_path / "again.BIN"))   # in one go, to compare
                erase_logs(link)
                got["after_erase"] = list_logs(link)
            except Exception as exc:  # reported by the assertions below
                got["error"] = repr(exc)
            finally:
                if link is not None:
                    link.close()
                done.set()

        threading.Thread(target=ground, daemon=True).start()

    # a drop in 1 m of water: on the bottom ~3 s after the release at ~9.5 s;
    # the operator disarms there at 16 s
    twin = Twin(Options(scenario="bottom-rest", radio="pty", speedup=2.0, duration=60.0,
                        operator=[Action(16.0, "disarm")], board_fs=str(tmp_path / "board")),
                on_radio=on_radio, on_frame=_stop_after(done, 3.0))
    twin.run()
    assert done.wait(30)
    assert "error" not in got, got["error"]
    assert "disarm first" in got["armed_text"]
    assert len(got["entries"]) == 1 and got["entries"][0]["id"] == 1
    assert got["part"] is True
    r = got["result"]
    assert 0 < r["resumed_bytes"] < r["size"] and r["size"] == got["entries"][0]["size"]
    # the resumed download is the log, byte for byte, as one in a go gets it
    assert got["whole"]["resumed_bytes"] == 0
    assert out.read_bytes() == (tmp_path / "again.BIN").read_bytes()
    # erased: none listed; the board's flash holds only the log prepared for the next dive
    assert got["after_erase"] == []
    assert [p.name for p in (tmp_path / "board" / "logs").glob("*.BIN")] == ["00000001.BIN"]
    assert (tmp_path / "board" / "logs" / "00000001.BIN").stat().st_size < out.stat().st_size
    # pymavlink's mavlogdump.py dumps it, every line a record
    dump = subprocess.run([sys.executable, str(Path(sys.executable).with_name("mavlogdump.py")), "--types", "ATT",
                           str(out)], capture_output=True, text=True, timeout=60)
    assert dump.returncode == 0 and dump.stdout.count("ATT {TimeUS") > 100
    log = DFReader.DFReader_binary(str(out))
    kinds = Counter()
    att = []
    while (m := log.recv_match()) is not None:
        kinds[m.get_type()] += 1
        if m.get_type() == "ATT":
            att.append(m.TimeUS)
    assert {"ATT", "IMU", "MAG", "BARO", "RCOU", "WING", "EST", "PM", "PARM", "MODE", "EV", "MSG"} <= set(kinds)
    # ATT at 25 Hz from arming to the disarming, less the calls a planned
    # stall takes (a collection every 300 ms, ~50 ms on the board): no gap
    # longer than the arming's parameter save (~100 ms) and two calls, three in five calls there (a slot that ends late passes the log to the next)
    assert 9.0 < att[0] / 1e6 < 10.0 and 15.5 < att[-1] / 1e6 < 16.5
    gaps = [b - a for a, b in zip(att, att[1:])]
    assert min(gaps) >= 30_000 and max(gaps) <= 200_000
    assert len(att) >= 0.6 * (att[-1] - att[0]) / 40_000


def test_a_watchdog_reset_mid_dive_leaves_a_readable_log_and_a_new_one_after_it(tmp_path):
    """target-landing, the loop hung at 20 s (the watchdog resets the board):
    the log prepared on deck stays readable (what the RAM held is lost with
    the reset), and the resumed dive's log is made once the vehicle rests on
    the bottom, with its records from the reset to the end."""
    from roboray.sim.twin import faults
    from roboray.sim.twin.runner import run

    r = run(Options(scenario="target-landing", interpreter="cpython", faults=[faults.parse("watchdog@20")],
                    board_fs=str(tmp_path)))
    assert r["resets"] == 1 and r["landing_error_m"] < 0.5
    logs = sorted((tmp_path / "logs").glob("*.BIN"))
    assert [p.name for p in logs] == ["00000001.BIN", "00000002.BIN"]
    first = Counter()
    log = DFReader.DFReader_binary(str(logs[0]))
    while (m := log.recv_match()) is not None:
        first[m.get_type()] += 1
    assert first["PARM"] > 50 and first["FMT"] > 10        # readable: its header and parameters
    second = DFReader.DFReader_binary(str(logs[1]))
    att = []
    while (m := second.recv_match()) is not None:
        if m.get_type() == "ATT":
            att.append(m.TimeUS / 1e6)
    # the board's clock restarts at the reset (about 21 s): from the resumed dive to its rest
    assert att and att[-1] - att[0] > 10.0


def test_a_log_listed_right_after_the_disarm_downloads_to_its_listed_size(tmp_path):
    # the ring still holds the dive's last records when the operator
    # disarms: the list gives the size the log will have once they are on
    # flash, and the download, however soon it starts, brings exactly that
    got: dict = {}
    done = threading.Event()

    def on_radio(radio):
        def ground():
            link = None
            try:
                link = Link(radio.device, 57600)
                link.wait_heartbeat(timeout=30)
                while not (link.vehicle_heartbeat.base_mode & 128):
                    link.wait_heartbeat(timeout=5)
                while link.vehicle_heartbeat.base_mode & 128:
                    link.wait_heartbeat(timeout=5)
                first = list_logs(link)          # at once
                got["listed"] = first[0].size
                got["result"] = download(link, first[0], str(tmp_path / "dive.BIN"))
                time.sleep(3.0)
                got["later"] = list_logs(link)[0].size
            except Exception as exc:  # reported by the assertions below
                got["error"] = repr(exc)
            finally:
                if link is not None:
                    link.close()
                done.set()

        threading.Thread(target=ground, daemon=True).start()

    twin = Twin(Options(scenario="bottom-rest", radio="pty", speedup=2.0, duration=40.0,
                        operator=[Action(16.0, "disarm")], board_fs=str(tmp_path / "board")),
                on_radio=on_radio, on_frame=lambda twin: done.is_set() and twin.stop())
    twin.run()
    assert done.wait(30)
    assert "error" not in got, got["error"]
    assert got["result"]["size"] == got["listed"] == got["later"], got
    mine = (tmp_path / "dive.BIN").read_bytes()
    board = (tmp_path / "board" / "logs" / "00000001.BIN").read_bytes()
    first = next((i for i, (x, y) in enumerate(zip(mine, board)) if x != y), None)
    assert mine == board, (len(mine), len(board), first, got)


def test_a_default_passive_drop_of_either_vehicle_loses_no_record(tmp_path):
    # the buildable vehicle sinks slower: armed at 9 s, resting (and
    # flushing) from about 43 s; with a 48 kB ring it dropped 296 records
    from roboray.ground.binplot import read
    from roboray.ground.series import gaps
    from roboray.sim.twin.runner import run

    for vehicle in (None, "sim/vehicles/buildable.py"):
        fs = tmp_path / ("board-%s" % ("reference" if vehicle is None else "buildable"))
        r = run(Options(scenario="passive-drop", vehicle=vehicle, board_fs=str(fs)))
        assert r["landed"], vehicle
        log = read((fs / "logs" / "00000001.BIN").read_bytes())
        texts = [m.Message for m in log.get("MSG", [])]
        assert not [t for t in texts if "dropped" in t], (vehicle, texts)
        assert sum(m.Drop for m in log["PM"]) == 0, vehicle
        att = [m.TimeUS / 1e6 for m in log["ATT"]]
        assert gaps(att) == [], (vehicle, gaps(att))
        assert att[-1] > r["landed_at_s"], vehicle     # recorded all the way to the bottom
