"""A ``roboray-sim sil`` session as a person runs it: Ctrl-C (SIGINT to the
process group, as a terminal sends it) on every interpreter, ``--linger``
keeping the vehicle on the radio after the scenario, the end of a real-time
run as the ground station on the pseudo-terminal sees it, and the progress
line on a terminal only. Real pymavlink and pyserial on the twin's
pseudo-terminal; the tlogs are read by pymavlink's own ``mavlogdump.py``."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from roboray.ground import tlog
from roboray.ground.link import EXIT_CLOSED, Link, LinkClosed
from roboray.sim.twin.ground import EPOCH_US


class Sil:
    """``roboray-sim sil`` in its own process group; stderr read as it comes."""

    def __init__(self, *args: str, stderr=None) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "roboray.sim.cli", "sil", *args],
                                     stdout=subprocess.PIPE, stderr=stderr or subprocess.PIPE, text=True,
                                     start_new_session=True)
        self.err: list = []
        self._reader = None
        if stderr is None:
            self._reader = threading.Thread(target=self._read, daemon=True)
            self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stderr:
            self.err.append(line.rstrip("\n"))

    def wait_for(self, words: str, timeout: float = 120.0) -> str:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for line in list(self.err):
                if words in line:
                    return line
            if self.proc.poll() is not None and not any(words in ln for ln in self.err):
                break
            time.sleep(0.1)
        raise AssertionError("no %r on stderr: %s" % (words, self.err))

    def ctrl_c(self) -> None:
        """What a terminal's Ctrl-C does: SIGINT to the whole process group."""
        os.killpg(self.proc.pid, signal.SIGINT)

    def finish(self, timeout: float = 120.0) -> tuple[int, str, str]:
        # stdout alone here: communicate() would read stderr too, from under the reader thread
        out = self.proc.stdout.read()
        self.proc.wait(timeout=timeout)
        if self._reader is not None:
            self._reader.join(timeout=10)
        return self.proc.returncode, out, "\n".join(self.err)


def mavlogdump(path: Path) -> list[str]:
    """The messages pymavlink's mavlogdump.py reads from a tlog."""
    script = Path(sys.executable).with_name("mavlogdump.py")
    r = subprocess.run([sys.executable, str(script), str(path)], capture_output=True, text=True, timeout=120,
                       env=dict(os.environ, MAVLINK20="1"))
    assert r.returncode == 0, r.stderr
    return r.stdout.splitlines()


def check_tlog(path: Path) -> list[dict]:
    """A whole tlog: every record complete, the same messages for
    mavlogdump and ``roboray-ground tlog dump``; the decoded records."""
    data = path.read_bytes()
    assert data and tlog.complete_length(data) == len(data)
    r = subprocess.run([sys.executable, "-m", "roboray.ground.cli", "tlog", "dump", str(path), "--json"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    ours = [json.loads(line) for line in r.stdout.splitlines()]
    assert all(m["crc_ok"] for m in ours)
    assert len(mavlogdump(path)) == len(ours) > 10
    return ours


def _interpreters() -> list:
    """Each interpreter (the default one with a radio, nobody on it)."""
    out = [pytest.param("micropython", ("--radio", "pty"), id="micropython-radio"),
           pytest.param("cpython", (), id="cpython")]
    try:
        from roboray.tools.micropython import unix_port

        unix_port.require()
        out.append(pytest.param("micropython-unix", (), id="micropython-unix"))
    except RuntimeError as exc:
        out.append(pytest.param("micropython-unix", (), marks=pytest.mark.skip(reason=str(exc))))
    try:
        from roboray.tools.micropython import rp2350_emu

        rp2350_emu.require()
        out.append(pytest.param("rp2350-emu", (), id="rp2350-emu"))
    except RuntimeError as exc:
        out.append(pytest.param("rp2350-emu", (), marks=pytest.mark.skip(reason=str(exc))))
    return out


@pytest.mark.parametrize("interpreter, extra", _interpreters())
def test_ctrl_c_stops_the_twin_and_reports_what_flew(interpreter, extra, tmp_path):
    log, png = tmp_path / "dive.tlog", tmp_path / "dive.png"
    sil = Sil("--interpreter", interpreter, "--scenario", "target-landing", "--speedup", "1", "--tlog", str(log),
              "--plot", str(png), "--json", *extra)
    link = None
    if extra:
        # a ground station on the radio: the vehicle is flying once it hears it
        link = Link(sil.wait_for("radio: /dev/pts/").split()[1])
        link.wait_heartbeat(240)
        assert link.wait(lambda m: m.get_type() == "ATTITUDE" and m.time_boot_ms >= 3000, 240) is not None
    else:
        # the vehicle is flying once its frames reach the tlog (buffered: a
        # few seconds of them)
        end = time.monotonic() + 240
        while time.monotonic() < end and sil.proc.poll() is None and not (log.exists() and log.stat().st_size):
            time.sleep(0.2)
    sil.ctrl_c()
    if link is not None:
        try:
            # and it sees the interrupted run's end as the link closed
            with pytest.raises(LinkClosed, match="link closed: the vehicle's port went away"):
                end = time.monotonic() + 120
                while time.monotonic() < end:
                    link.recv(0.5)
        finally:
            link.close()
    code, out, err = sil.finish()
    assert code == 130, err
    assert err.splitlines()[-1] == "roboray-sim: interrupted" and "Traceback" not in err
    assert "simulated:" not in err     # no progress when stderr is not a terminal
    report = json.loads(out)
    assert report["interrupted"] is True
    assert 0 < report["duration_s"] == report["interrupted_at_s"]
    assert report["frames"] > 0 and report["overruns"] is not None   # the board's own report came
    assert report["landed"] is False and report["plot"] == str(png) and report["tlog"] == str(log)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    records = check_tlog(log)
    # the record ends where the run stopped (the radio's last burst within a second of it)
    end = EPOCH_US / 1e6 + report["duration_s"]
    assert end - 1.0 <= records[-1]["timestamp"] <= end + 0.001


def test_ctrl_c_twice_stops_at_once_and_still_reports(tmp_path):
    """The second SIGINT raises in the host wherever it is; the report is
    made of what the host saw, the tlog is whole."""
    import threading as th

    from roboray.sim.twin.runner import Options, Twin

    if th.current_thread() is not th.main_thread():
        pytest.skip("signals reach only the main thread")
    log = tmp_path / "abort.tlog"
    sent = []
    before = signal.getsignal(signal.SIGINT)

    def on_frame(twin) -> None:
        if twin.world.t >= 2.0 and len(sent) < 2:
            sent.append(twin.world.t)
            os.kill(os.getpid(), signal.SIGINT)

    twin = Twin(Options(scenario="passive-drop", interpreter="cpython", tlog=str(log)), on_frame=on_frame,
                interruptible=True)
    report = twin.run()
    assert len(sent) == 2 and report["interrupted"] is True
    assert report["frames"] is None     # the board never sent its report
    assert report["duration_s"] == pytest.approx(sent[-1] + 0.02, abs=0.05)
    check_tlog(log)
    assert signal.getsignal(signal.SIGINT) == before


def test_linger_keeps_the_vehicle_on_the_radio_until_ctrl_c(tmp_path):
    log = tmp_path / "linger.tlog"
    sil = Sil("--interpreter", "cpython", "--radio", "pty", "--linger", "--duration", "4", "--tlog", str(log),
              "--json")
    device = sil.wait_for("radio: /dev/pts/").split()[1]
    sil.wait_for("the scenario is over; the vehicle stays on the radio")
    link = Link(device)
    try:
        link.wait_heartbeat(30)
        t0, boot0 = time.monotonic(), None
        beats = 0
        while time.monotonic() - t0 < 4.0:
            m = link.recv(0.5)
            if m is None:
                continue
            if m.get_type() == "HEARTBEAT":
                beats += 1
            if m.get_type() == "ATTITUDE":
                if boot0 is None:
                    boot0, w0 = m.time_boot_ms, time.monotonic()
                boot1, w1 = m.time_boot_ms, time.monotonic()
        # alive, and paced to real time after a scenario run as fast as possible
        assert beats >= 2 and boot0 is not None and boot1 > boot0
        # (the radio's buffer may hold up to a second from the fast part)
        assert (boot1 - boot0) / 1000.0 < 1.5 * (w1 - w0) + 1.0
        sil.ctrl_c()
        with pytest.raises(LinkClosed, match="link closed: the vehicle's port went away \\(%s\\)" % device):
            end = time.monotonic() + 60
            while time.monotonic() < end:
                link.recv(0.5)
    finally:
        link.close()
    code, out, err = sil.finish()
    assert code == 0, err     # the scenario had ended: Ctrl-C is how a lingering run ends
    report = json.loads(out)
    assert report["interrupted"] is False and report["duration_s"] == 4.0 and report["lingered_s"] > 3.0
    # the operator's script stopped with the scenario: never released
    assert report["released_at_s"] is None
    check_tlog(log)


def test_a_real_time_run_ends_with_the_link_closed_for_watch():
    sil = Sil("--radio", "pty", "--speedup", "1", "--duration", "8")
    device = sil.wait_for("radio: /dev/pts/").split()[1]
    watch = subprocess.run([sys.executable, "-m", "roboray.ground.cli", "watch", "--master", device, "--plain"],
                           capture_output=True, text=True, timeout=180)
    code, out, err = sil.finish()
    assert code == 0, err
    assert watch.returncode == EXIT_CLOSED, watch.stderr
    assert watch.stderr == "roboray-ground: error: link closed: the vehicle's port went away (%s)\n" % device
    assert any("disarmed" in ln or "ARMED" in ln for ln in watch.stdout.splitlines()), watch.stdout


def test_progress_on_a_terminal_and_not_with_json():
    import fcntl
    import struct
    import termios

    # a terminal of 100 columns, then the same with --json
    for extra, size, shown in (((), (30, 100), True), (("--json",), (30, 100), False)):
        master, slave = os.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", size[0], size[1], 0, 0))
        try:
            sil = Sil("--interpreter", "cpython", "--speedup", "1", "--duration", "3", *extra, stderr=slave)
            os.close(slave)
            seen = b""
            while True:
                try:
                    chunk = os.read(master, 4096)
                except OSError:     # EIO: the run closed its end
                    break
                if not chunk:
                    break
                seen += chunk
            code, out, _ = sil.finish()
        finally:
            os.close(master)
        text = seen.decode(errors="replace")
        assert code == 0, text
        # sim/progress.py's bar: "simulated: 2/3 s|###   | 00:02<00:01"
        drawn = re.search(r"simulated: \d/3 s\|.*\| \d\d:\d\d<\d\d:\d\d", text) is not None
        assert drawn == shown, text
    assert json.loads(out)["duration_s"] == 3.0


def test_linger_needs_a_radio():
    r = subprocess.run([sys.executable, "-m", "roboray.sim.cli", "sil", "--interpreter", "cpython", "--linger"],
                       capture_output=True, text=True, timeout=120)
    lines = [ln for ln in r.stderr.splitlines() if not ln.startswith("roboray.")]
    assert r.returncode == 2 and lines == ["roboray-sim: error: --linger keeps the vehicle alive for a ground "
                                           "station after the scenario: give --radio too"], r.stderr


def test_trim_cuts_only_an_unfinished_last_record(tmp_path):
    from roboray.sim.twin.ground import Ground

    path = tmp_path / "cut.tlog"
    with open(path, "wb") as f:
        g = Ground([], f)
        for k in range(20):
            g.t = k * 0.1
            g.mav.heartbeat_send(6, 8, 0, 0, 0)
            g.take()
    whole = path.read_bytes()
    assert tlog.trim(str(path)) == 0 and path.read_bytes() == whole
    path.write_bytes(whole + whole[:13])      # a writer stopped 13 bytes into a record
    assert tlog.trim(str(path)) == 13 and path.read_bytes() == whole
    damaged = bytearray(whole)
    damaged[29 + 8] = 0x00                    # the 2nd frame's start: damage inside is not a writer's
                                              # cut, and is left for records() to skip and report
    path.write_bytes(bytes(damaged))
    assert tlog.trim(str(path)) == 0 and path.read_bytes() == bytes(damaged)
