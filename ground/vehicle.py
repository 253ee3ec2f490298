"""A vehicle endpoint on the real MicroPython interpreter, behind a pseudo-terminal.

The board's MAVLink endpoint (``shared/mavlink/endpoint.py``) runs unchanged
in the MicroPython WebAssembly port. Its transport's ``read_into`` and
``write`` cross to CPython through ``hostlink.request``; this side moves the
bytes to and from the master of a pseudo-terminal, whose slave
(``device``, e.g. ``/dev/pts/5``) the ground station opens like a radio's
serial port. The tests drive it with ``roboray-ground``; ``roboray-ground
demo-vehicle`` serves it for a person.

With ``animate`` the telemetry moves (a scripted slow descent with a
turning heading and swinging wings) so a ``watch`` screen has something to
show; it is a demonstration, not a simulation. The main loop's figures are
scripted too, as the firmware's scheduler would report them: a load of
43.1 % and a worst slot of 6.8 ms held still, wandering around those with
``animate``.

Signing is the firmware's: the key and the signing clock live in
``/signing.bin`` on the interpreter's file system, a ``FlashRecord`` kept by
``firmware/link.py``'s ``SigningKeeper`` (loaded at boot with the clock past
the saved one, saved at SETUP_SIGNING, at disarm and as the clock runs).
``restart()`` is a reset of the board: a new interpreter, the same
pseudo-terminal, the signing record carried across (the only thing kept:
parameters and modes start from their defaults).

Its parameters are the flight firmware's, every one (``firmware/app.py``
``PARAMS``: the shared ones and the drivers', navigation's, the failsafes'
and the controller's), so ``param list`` here shows what a board shows.
"""

from __future__ import annotations

import os
import select
import threading
import tty
from typing import Optional

from roboray.tools.micropython import MicroPython

# Runs inside MicroPython. %(...)s fields are filled in below.
_BOARD = """
import time, math, hostlink, binascii
from roboray.shared import modes, quat
from roboray.shared.params import ParamTable
from roboray.shared.mavlink.endpoint import Endpoint
from roboray.shared.mavlink.telemetry import Telemetry
from roboray.shared.mavlink.signing import Signing
from roboray.firmware.flash_record import FlashRecord
from roboray.firmware.link import SigningKeeper

class HostlinkTransport:
    # the firmware's radio driver offers the same two methods
    def read_into(self, buf):
        data = binascii.unhexlify(hostlink.request('r%%d' %% len(buf)))
        n = len(data)
        buf[0:n] = data
        return n
    def write(self, buf):
        hostlink.request('w' + binascii.hexlify(bytes(buf)).decode())

class Checks:
    def arming_check(self):
        return modes.LEAK if __leak else None
    def mode_check(self, mode):
        if mode == modes.TARGET and not __tel.has_target:
            return modes.NO_TARGET
        return None

__leak = False
__params = ParamTable(%(params)s)
__params.set_by_name('SYSID_THISMAV', %(sysid)d)
__modes = modes.Modes(Checks())
__tel = Telemetry()
__tel.battery[0] = 7.9
__tel.battery[1] = 0.4
__tel.battery[2] = 0.93
__signing = Signing()
__keeper = SigningKeeper(__signing, FlashRecord('/signing.bin'))
if not __keeper.load() and %(key)s is not None:
    __signing.set_key(%(key)s)
    __keeper.save()
__ep = Endpoint(HostlinkTransport(), __params, __modes, __tel, __signing)
__ep.on_setup_signing = __keeper.save
__tel.load_permille = 431

def __loop_figures(t):
    # what firmware/link.py passes on from the scheduler: its load (permille)
    # and the time of every slot (us), the longest of which the status sends
    __tel.load_permille = 431 + int(40.0 * math.sin(0.4 * t))
    slot = 6800 + int(1500.0 * math.sin(1.3 * t))
    if slot > __ep.slot_max_us:
        __ep.slot_max_us = slot

def __animate(t):
    d = 0.05 * t
    __tel.env[0] = d
    __tel.env[1] = 101325.0 + 9806.65 * d
    __tel.env[2] = 18.5
    __tel.pos_ned[0] = 0.02 * t
    __tel.pos_ned[1] = 0.01 * t
    __tel.pos_ned[2] = d
    __tel.vel_ned[0] = 0.02
    __tel.vel_ned[1] = 0.01
    __tel.vel_ned[2] = 0.05
    quat.from_euler(__tel.q, 0.05 * math.sin(0.7 * t), 0.04 * math.cos(0.5 * t), 0.1 * t)
    __tel.rates[2] = 0.1
    for i in range(4):
        a = 45.0 + 10.0 * math.sin(0.3 * t + i)
        __tel.servo_deg[i] = a
        __tel.servo_us[i] = int(1500 + a * 10)
    __tel.battery[0] = 7.9 - 0.0005 * t

def __serve(animate):
    t0 = time.ticks_ms()
    while True:
        now = time.ticks_ms()
        if animate:
            t = time.ticks_diff(now, t0) / 1000.0
            __loop_figures(t)
            if __modes.armed:
                __animate(t)
        elif __ep.slot_max_us < 6800:
            __ep.slot_max_us = 6800
        __ep.update(now)
        __keeper.service(now, __modes.armed)
        if __ep.reboot_requested:
            __ep.reboot_requested = False
            hostlink.request('reboot')
        if hostlink.request('s') == 'q':
            return
"""


def _params_source() -> str:
    """The firmware's parameter declarations (``firmware/app.py`` PARAMS) as
    source: the demonstration vehicle has the flight firmware's parameter
    set, not a part of it."""
    from roboray.firmware.app import PARAMS

    return repr(tuple(tuple(d) for d in PARAMS))


class PtyVehicle:
    """Serve the board endpoint behind a pseudo-terminal until ``close()``.

    Parameters
    ----------
    key:
        32-byte signing key for the vehicle, or None.
    sysid:
        The vehicle's SYSID_THISMAV.
    animate:
        Move the telemetry (demonstration) instead of holding it still.
    tick_s:
        How long the vehicle loop waits for radio bytes between updates.

    ``key`` is put on the vehicle's flash as SETUP_SIGNING would, with its
    clock never set (it takes the first signed frame's time).
    """

    #: The signing record's files on the vehicle's flash (FlashRecord's three).
    RECORD_FILES = ("/signing.bin", "/signing.bin.tmp", "/signing.bin.bak")

    def __init__(self, key: Optional[bytes] = None, sysid: int = 1, animate: bool = False,
                 tick_s: float = 0.01) -> None:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        tty.setraw(self._master)
        os.set_blocking(self._master, False)
        #: What the ground station opens, like /dev/ttyUSB0.
        self.device = os.ttyname(self._slave)
        self.tick_s = tick_s
        self.reboots = 0    # reboots the vehicle was asked for (PREFLIGHT_REBOOT_SHUTDOWN)
        self.restarts = 0   # restart() calls
        self.error: Optional[BaseException] = None
        self._stop = threading.Event()
        self._sysid = sysid
        self._animate = animate
        self._mp = self._boot({}, key)
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _boot(self, files: dict, key: Optional[bytes] = None) -> MicroPython:
        mp = MicroPython(on_request=self._on_request)
        try:
            mp.install_board_code()
            for path, data in files.items():
                mp.write_file(path, data)
            mp.exec(_BOARD % {"sysid": self._sysid, "key": "None" if key is None else repr(bytes(key)),
                              "params": _params_source()})
        except BaseException:
            mp.close()
            raise
        return mp

    def record(self) -> dict:
        """The signing record's files on the vehicle's flash, path -> bytes
        (use only while the vehicle is stopped)."""
        files = {}
        for path in self.RECORD_FILES:
            if self._mp.eval("__keeper.record.fs.exists(%r)" % path):
                files[path] = self._mp.read_file(path)
        return files

    def restart(self) -> None:
        """Reset the board, as a watchdog would: the loop stops where it is
        (nothing saved at the end), a new interpreter boots from the same
        flash (the signing record) behind the same pseudo-terminal."""
        self.stop()
        files = self.record()
        self._mp.close()
        self._mp = self._boot(files)
        self.restarts += 1
        self.resume()

    @property
    def interpreter(self) -> MicroPython:
        """The MicroPython interpreter (use only while the vehicle is stopped)."""
        return self._mp

    def start(self) -> "PtyVehicle":
        self._thread.start()
        return self

    def _run(self) -> None:
        try:
            self._mp.exec("__serve(%s)" % self._animate)
        except BaseException as exc:  # reported to the owner by close()
            self.error = exc

    def _on_request(self, text: str) -> str:
        if text == "reboot":   # before the one-letter requests: it starts with "r"
            self.reboots += 1
            return ""
        op = text[:1]
        if op == "r":
            try:
                data = os.read(self._master, int(text[1:]))
            except BlockingIOError:
                data = b""
            except OSError:
                data = b""
            return data.hex()
        if op == "w":
            data = bytes.fromhex(text[1:])
            try:
                os.write(self._master, data)
            except OSError:
                pass  # nobody listening: a radio drops bytes too
            return ""
        if op == "s":
            if self._stop.is_set():
                return "q"
            select.select([self._master], [], [], self.tick_s)
            return ""
        return ""

    def stop(self) -> None:
        """Stop the vehicle loop (the radio falls silent); the interpreter stays usable."""
        self._stop.set()
        self._thread.join(timeout=30)

    def resume(self) -> None:
        """Start the loop again after ``stop()``, with the state it had."""
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def close(self) -> None:
        self.stop()
        self._mp.close()
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass

    def __enter__(self) -> "PtyVehicle":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()
