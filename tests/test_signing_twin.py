"""Signing on the firmware in the twin, with pymavlink as the attacker.

``roboray-sim sil``'s twin (the real firmware on MicroPython, its key record
on the board's flash, ``--key``) serves its radio on a pseudo-terminal
(``--radio pty``); an attacker with a radio on that link tries an unsigned
command, a wrong key, a recorded frame replayed, a far-future frame and,
after a watchdog reset of the board, the recording again. Each is refused,
leaves the vehicle's parameter as it was and counts in SYS_STATUS; the
legitimate ground (``roboray-ground --key``, a subprocess) still works,
and its first frames after the reset are not refused: it signs from the
vehicle's clock (ground/link.py), which the twin starts years behind the
wall clock and the reset moves two minutes further.

``Attacker`` and ``attack`` serve the demo vehicle's test too
(tests/test_ground_cli.py).
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from typing import Callable, Optional

import pytest

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as pm  # noqa: E402

from roboray.shared.mavlink.signing import key_from_passphrase  # noqa: E402

PASSPHRASE = "ballast"
PARAM = "FS_GCS_TIMEOUT"
FUTURE = 11 * 60 * 100000     # 11 minutes in signing units: past the vehicle's 10-minute bound


def ground(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "roboray.ground.cli", *args],
                          capture_output=True, text=True, timeout=timeout)


class _Sink:
    def __init__(self) -> None:
        self.data = bytearray()

    def write(self, b: bytes) -> None:
        self.data += b


class Attacker:
    """A radio on the vehicle's link: pymavlink without a key reads what the
    vehicle sends (signed frames unchecked), and frames go out as made."""

    def __init__(self, device: str) -> None:
        self.conn = mavutil.mavlink_connection(device, baud=57600, source_system=254, dialect="common",
                                               autoreconnect=False)
        self.conn.mav.robust_parsing = True

    def close(self) -> None:
        self.conn.close()

    def recv(self, timeout: float):
        m = self.conn.recv_match(blocking=True, timeout=timeout)
        return None if m is None or m.get_type() == "BAD_DATA" else m

    def clock(self, timeout: float = 10.0) -> int:
        """The vehicle's signing clock: the timestamp of its next signed frame."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            m = self.recv(0.5)
            if m is not None and m.get_msgbuf()[2] & 1:
                return int.from_bytes(bytes(m.get_msgbuf()[-12:-6]), "little")
        raise AssertionError("no signed frame from the vehicle within %g s" % timeout)

    def counts(self, timeout: float = 10.0) -> tuple[int, int]:
        """SYS_STATUS errors_count2 (unsigned, wrong key), errors_count3 (replayed, old, far-future)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            m = self.recv(0.5)
            if m is not None and m.get_type() == "SYS_STATUS":
                return m.errors_count2, m.errors_count3
        raise AssertionError("no SYS_STATUS within %g s" % timeout)

    def settled_counts(self, want: tuple[int, int], timeout: float = 10.0) -> tuple[int, int]:
        """The counts once they reach ``want`` (a status report may predate a refusal)."""
        end = time.monotonic() + timeout
        got = self.counts()
        while got != want and time.monotonic() < end:
            got = self.counts()
        return got

    @staticmethod
    def frame(value: float, key: Optional[bytes] = None, ts: int = 0, link: int = 5) -> bytes:
        """A PARAM_SET of ``PARAM`` from system 254: unsigned, or signed with ``key`` at ``ts``."""
        sink = _Sink()
        mav = pm.MAVLink(sink, srcSystem=254, srcComponent=190)
        if key is not None:
            mav.signing.secret_key = key
            mav.signing.link_id = link
            mav.signing.timestamp = ts
            mav.signing.sign_outgoing = True
        mav.param_set_send(1, 1, PARAM.encode(), value, pm.MAV_PARAM_TYPE_REAL32)
        return bytes(sink.data)

    def send(self, frame: bytes) -> None:
        self.conn.write(frame)

    def echo(self, timeout: float = 1.5) -> Optional[float]:
        """The vehicle's PARAM_VALUE of ``PARAM`` (it answers a PARAM_SET it took), or None."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            m = self.recv(0.2)
            if m is not None and m.get_type() == "PARAM_VALUE" and m.param_id == PARAM:
                return m.param_value
        return None


def attack(device: str, restart: Callable[[], None], *ground_args: str) -> dict:
    """The attack sequence on the vehicle behind ``device``, with a restart of
    the vehicle (``restart()``) in the middle; asserts as it goes and returns
    what it saw. ``ground_args``: more ``roboray-ground`` options."""
    key = key_from_passphrase(PASSPHRASE)
    legit = ("--master", device, "--key", PASSPHRASE) + ground_args
    seen: dict = {}

    # the legitimate ground talks first (a vehicle whose clock was never set takes its time)
    r = ground("param", "get", PARAM, *legit)
    assert r.returncode == 0, r.stderr
    a = Attacker(device)
    try:
        e2, e3 = a.counts()
        # the legitimate ground sets the parameter twice; the attacker records the first frame
        ts = a.clock()
        recorded = a.frame(7, key, ts + 1)
        a.send(recorded)
        assert a.echo() == 7
        a.send(a.frame(8, key, ts + 2))
        assert a.echo() == 8
        # unsigned: refused
        a.send(a.frame(30))
        assert a.echo() is None
        # wrong key: refused
        a.send(a.frame(31, key_from_passphrase("guess"), ts + 3))
        assert a.echo() is None
        # the recorded frame again: refused
        a.send(recorded)
        assert a.echo() is None
        # a far-future frame with the right key (on a stream of its own): refused, not adopted
        a.send(a.frame(32, key, a.clock() + FUTURE, link=6))
        assert a.echo() is None
        got = a.settled_counts((e2 + 2, e3 + 2))
        assert got == (e2 + 2, e3 + 2), (got, (e2, e3))
        seen["before"] = got
    finally:
        a.close()

    # the legitimate ground still works, and the vehicle refused nothing of it
    r = ground("param", "set", PARAM, "9", *legit)
    assert (r.returncode, r.stdout.strip()) == (0, "%s 9.0 (was 8.0)" % PARAM), r.stderr
    a = Attacker(device)
    try:
        assert a.settled_counts(seen["before"]) == seen["before"]
    finally:
        a.close()

    restart()

    a = Attacker(device)
    try:
        e2, e3 = a.counts()
        seen["after_restart"] = (e2, e3)
        # the recording after the restart: refused (older than the vehicle's clock less a minute)
        a.send(recorded)
        assert a.echo() is None
        assert a.settled_counts((e2, e3 + 1)) == (e2, e3 + 1)
    finally:
        a.close()
    # the legitimate ground, its clock behind or ahead of the vehicle's: works at once
    r = ground("param", "set", PARAM, "10", *legit)
    assert r.returncode == 0 and r.stdout.startswith("%s 10.0 (was " % PARAM), r.stderr
    assert "(was 7.0)" not in r.stdout                # the replay set nothing
    seen["was"] = r.stdout.strip()
    a = Attacker(device)
    try:
        assert a.settled_counts((e2, e3 + 1)) == (e2, e3 + 1)   # none of its frames refused
    finally:
        a.close()
    return seen


class Reset:
    """Waits for the twin's watchdog reset: the vehicle falls silent (its loop
    hangs until the watchdog bites), then boots and says so."""

    def __init__(self, device: str) -> None:
        self.device = device

    def __call__(self) -> None:
        a = Attacker(self.device)
        try:
            end = time.monotonic() + 120
            quiet = False
            while time.monotonic() < end:
                m = a.recv(1.0)
                if m is None:
                    quiet = True
                elif quiet and m.get_type() == "STATUSTEXT" and "watchdog reset" in m.text:
                    return
            raise AssertionError("the board did not reset")
        finally:
            a.close()


@pytest.mark.slow
def test_attacks_on_the_firmware_in_the_twin_then_the_legitimate_ground():
    from roboray.sim.twin import faults
    from roboray.sim.twin.runner import Options, Twin

    got: dict = {}
    done = threading.Event()

    def on_radio(radio):
        def run() -> None:
            try:
                got.update(attack(radio.device, Reset(radio.device), "--source-system", "254"))
            except BaseException as exc:   # reported by the assertions below
                got["error"] = exc
            finally:
                done.set()

        threading.Thread(target=run, daemon=True).start()

    # real time: the board resets at 18 s, well after the first attacks (~10 s of
    # wall time), and runs long enough for the ground after the reset
    r = Twin(Options(scenario="bottom-rest", radio="pty", speedup=1.0, duration=38.0, key=PASSPHRASE,
                     faults=[faults.parse("watchdog@18")]), on_radio=on_radio,
             on_frame=lambda twin: done.is_set() and twin.stop()).run()
    assert done.wait(60)
    if "error" in got:
        raise got["error"]
    assert r["resets"] == 1
    assert got["before"] == (2, 2) and got["after_restart"] == (0, 0)
