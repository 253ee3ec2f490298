"""A connection to a MicroPython board, through mpremote's serial transport.

:class:`Board` is the flashing tool's transport layer: it opens the port
with :class:`mpremote.transport_serial.SerialTransport`, interrupts whatever
runs to reach the raw REPL, and offers the few file operations a deployment
needs, each done by code run on the board with ``SerialTransport.exec``:

- ``survey``: the board's manifest, the sizes of many files, free space and
  the ``.mpy`` version it loads, in one round trip;
- ``hashes``: SHA-256 of many files, computed on the board (``hashlib``);
- ``put``: a file written to ``<name>.~new``, hashed on the board, and
  renamed over ``<name>`` only when the hash is the one expected, so a cut
  connection never leaves half a module in place;
- ``remove``, ``mkdirs`` and ``restart`` (soft reset, then the start-up
  output read back);
- ``identity`` (which MicroPython build runs) and ``bootloader`` (into
  BOOTSEL, for ``roboray-flash firmware``).

Content travels base64-encoded, 3 kB a command: a third more bytes than
the data, where mpremote's ``fs_writefile`` sends ``repr()`` of 256-byte
chunks (up to four times the data for compiled code) in many more round
trips. Failures become the typed errors of :mod:`.errors`.
"""

from __future__ import annotations

import base64
import contextlib
import io
import json
import logging
import os
import time
from typing import Iterable, Optional

import serial
from mpremote.transport import TransportError, TransportExecError
from mpremote.transport_serial import SerialTransport

from . import buildinfo
from .errors import (
    AppDidNotStart, BoardError, BoardNotAnswering, ConnectionLost, HashMismatch, NotEnoughSpace,
    PortUnavailable,
)

log = logging.getLogger("roboray.flash")

#: Suffix of a file while it is being written; renamed away once verified.
TMP_SUFFIX = ".~new"

#: File bytes a command carries (base64: 4 kB of text a command).
CHUNK_BYTES = 3072
#: File bytes a read brings back (base64 on the board's stdout).
GET_CHUNK_BYTES = 6144

# Helpers defined once a session in the board's REPL namespace. MicroPython
# code: it runs on the board.
_PRELUDE = """\
import os, sys, json, hashlib, binascii
def _rf_size(p):
    try:
        return os.stat(p)[6]
    except OSError:
        return -1
def _rf_sha(p):
    h = hashlib.sha256()
    b = bytearray(2048)
    v = memoryview(b)
    with open(p, 'rb') as f:
        while True:
            n = f.readinto(b)
            if not n:
                break
            h.update(v[:n])
    return binascii.hexlify(h.digest()).decode()
def _rf_hashes(ps):
    r = []
    for p in ps:
        try:
            r.append(_rf_sha(p))
        except OSError:
            r.append(None)
    print(json.dumps(r))
def _rf_survey(m, ps):
    try:
        with open(m) as f:
            t = f.read()
    except OSError:
        t = None
    s = os.statvfs('/')
    print(json.dumps({'manifest': t, 'sizes': [_rf_size(p) for p in ps], 'block': s[1],
        'free_blocks': s[4], 'blocks': s[2], 'mpy': getattr(sys.implementation, '_mpy', None),
        'machine': getattr(sys.implementation, '_machine', sys.platform),
        'build': getattr(sys.implementation, '_build', None), 'version': os.uname().version}))
def _rf_mkdirs(ds):
    for d in ds:
        if _rf_size(d) < 0:
            os.mkdir(d)
_rf_f = None
def _rf_open(p):
    global _rf_f
    _rf_f = open(p, 'wb')
def _rf_put(s):
    _rf_f.write(binascii.a2b_base64(s))
def _rf_commit(tmp, dst, want):
    global _rf_f
    _rf_f.close()
    _rf_f = None
    got = _rf_sha(tmp)
    if got == want:
        os.rename(tmp, dst)
    else:
        os.remove(tmp)
    print(got)
def _rf_ls(d):
    r = []
    try:
        for n in os.listdir(d):
            r.append([n, _rf_size(d + '/' + n)])
    except OSError:
        pass
    print(json.dumps(r))
def _rf_get(p, o, n):
    with open(p, 'rb') as f:
        f.seek(o)
        print(binascii.b2a_base64(f.read(n)).decode().strip())
def _rf_remove(ps, ds):
    for p in ps:
        if _rf_size(p) >= 0:
            os.remove(p)
    for d in ds:
        try:
            os.rmdir(d)
        except OSError:
            pass
"""


@contextlib.contextmanager
def _quiet():
    """mpremote prints what it received when entering the REPL fails; keep
    stdout for our one JSON document and log that text instead."""
    buf = io.StringIO()
    try:
        with contextlib.redirect_stdout(buf):
            yield
    finally:
        if buf.getvalue().strip():
            log.debug("mpremote: %s", buf.getvalue().strip())


class Board:
    """A board at the raw REPL. Use as ``with Board(port) as board: ...``.

    Parameters
    ----------
    device:
        Serial port (``/dev/ttyACM0``, ``COM3``, a pseudo-terminal).
    timeout_s:
        Longest wait for the board to answer at all, and the serial read
        timeout; a board that says nothing for this long is not answering.
    """

    def __init__(self, device: str, timeout_s: float = 10.0) -> None:
        if timeout_s <= 0:
            raise ValueError("timeout_s must be > 0, got %r" % timeout_s)
        self.device = device
        self.timeout_s = timeout_s
        #: Bytes written to the serial port so far: commands and content.
        self.bytes_written = 0
        self._t: Optional[SerialTransport] = None
        self._restarted = False

    # ------------------------------------------------------------- lifetime
    def __enter__(self) -> "Board":
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def connect(self) -> None:
        """Open the port, interrupt the application, enter the raw REPL."""
        if "://" not in self.device and not os.path.exists(self.device):
            raise PortUnavailable("no such port: %s (is the board plugged in? --port auto finds it)" % self.device)
        try:
            with _quiet():
                t = self._t = SerialTransport(self.device, baudrate=115200, timeout=self.timeout_s)
        except TransportError:
            raise self._diagnose() from None
        write = t.serial.write

        def counted(data: bytes) -> Optional[int]:
            self.bytes_written += len(data)
            return write(data)

        t.serial.write = counted  # type: ignore[method-assign]
        try:
            with _quiet():
                # Ctrl-C stops the application, Ctrl-A enters the raw REPL,
                # Ctrl-D there soft-resets without running main.py: a clean heap.
                t.enter_raw_repl(soft_reset=True, timeout_overall=self.timeout_s)
        except TransportError:
            self.close()
            raise BoardNotAnswering(
                "the board on %s is not answering: no MicroPython REPL within %g s "
                "(is MicroPython installed? unplug and replug the board)" % (self.device, self.timeout_s)
            ) from None
        except (serial.SerialException, OSError) as exc:
            self.close()
            raise ConnectionLost("connection to %s lost: %s" % (self.device, exc)) from None
        self.exec(_PRELUDE, "setting up")

    def _diagnose(self) -> Exception:
        """Why the port did not open, from pyserial's own exception."""
        try:
            serial.Serial(self.device, exclusive=True).close()
        except serial.SerialException as exc:
            text = str(exc)
            if "exclusively lock" in text or getattr(exc, "errno", None) in (11, 16):
                return PortUnavailable("port %s is busy: another program (a serial console, mpremote, "
                                       "Thonny, a running roboray-flash) has it open" % self.device)
            if getattr(exc, "errno", None) == 13 or "ermission" in text:
                return PortUnavailable("not permitted to open %s: add your user to the port's group "
                                       "(sudo usermod -aG dialout $USER, then log in again)" % self.device)
            return PortUnavailable("cannot open %s: %s" % (self.device, text))
        return PortUnavailable("cannot open %s (it may be in use by another program)" % self.device)

    def close(self) -> None:
        """Leave the board at its friendly REPL (unless restarted) and close."""
        t, self._t = self._t, None
        if t is None:
            return
        try:
            if t.in_raw_repl and not self._restarted:
                t.exit_raw_repl()
            t.close()
        except (TransportError, serial.SerialException, OSError):
            pass

    # ------------------------------------------------------------- commands
    def exec(self, code: str, what: str) -> bytes:
        """Run ``code`` on the board; its output. ``what`` names it in errors."""
        if self._t is None:
            raise ConnectionLost("not connected to %s" % self.device)
        try:
            return self._t.exec(code)
        except TransportExecError as exc:
            lines = exc.error_output.strip().splitlines()
            last = lines[-1] if lines else "no message"
            if "ENOSPC" in last:
                raise NotEnoughSpace("the board's file system is full (%s while %s)" % (last, what)) from None
            raise BoardError("the board failed while %s: %s" % (what, last)) from None
        except (TransportError, serial.SerialException, OSError) as exc:
            raise ConnectionLost("connection to the board on %s lost while %s: %s"
                                 % (self.device, what, exc or type(exc).__name__)) from None

    def _json(self, code: str, what: str):
        out = self.exec(code, what)
        try:
            return json.loads(out)
        except ValueError:
            raise ConnectionLost("garbled answer from the board while %s: %r" % (what, out[-80:])) from None

    def survey(self, manifest_path: str, paths: list[str]) -> dict:
        """Manifest text (or None), sizes (-1 = absent), free space, ``.mpy`` version."""
        s = self._json("_rf_survey(%r, %r)" % (manifest_path, paths), "reading its files")
        s["sizes"] = dict(zip(paths, s["sizes"]))
        s["free_bytes"] = s["block"] * s["free_blocks"]
        return s

    def hashes(self, paths: list[str]) -> dict[str, Optional[str]]:
        """SHA-256 (hex) of each file, computed on the board; None if absent."""
        if not paths:
            return {}
        return dict(zip(paths, self._json("_rf_hashes(%r)" % (paths,), "hashing its files")))

    def mkdirs(self, dirs: Iterable[str]) -> None:
        """Create folders, parents first (``dirs`` sorted so)."""
        dirs = list(dirs)
        if dirs:
            self.exec("_rf_mkdirs(%r)" % (dirs,), "creating folders")

    def put(self, path: str, data: bytes, sha256: str) -> None:
        """Write ``path`` atomically: temporary name, verified, renamed."""
        tmp = path + TMP_SUFFIX
        chunks = [data[i:i + CHUNK_BYTES] for i in range(0, len(data), CHUNK_BYTES)] or [b""]
        out = b""
        for i, chunk in enumerate(chunks):
            lines = ["_rf_open(%r)" % tmp] if i == 0 else []
            if chunk:
                lines.append("_rf_put(%r)" % base64.b64encode(chunk))
            if i == len(chunks) - 1:
                lines.append("_rf_commit(%r, %r, %r)" % (tmp, path, sha256))
            out = self.exec("\n".join(lines), "writing " + path)
        got = out.decode(errors="replace").strip()
        if got != sha256:
            raise HashMismatch(
                "hash mismatch after copying %s: the board read back sha256 %s, expected %s; "
                "the old file was left in place (a noisy cable? deploy again)" % (path, got[:16], sha256[:16])
            )

    def listdir(self, folder: str) -> dict[str, int]:
        """Names in ``folder`` with their sizes (-1: a folder); {} when it is missing."""
        return {n: size for n, size in self._json("_rf_ls(%r)" % folder, "listing " + folder)}

    def get(self, path: str, size: int, progress=None) -> bytes:
        """The bytes of ``path`` (``size`` of them), read in base64 chunks;
        checked against the SHA-256 the board computes."""
        out = bytearray()
        while len(out) < size:
            text = self.exec("_rf_get(%r, %d, %d)" % (path, len(out), GET_CHUNK_BYTES), "reading " + path)
            try:
                chunk = base64.b64decode(text.strip())
            except ValueError:
                raise ConnectionLost("garbled answer from the board while reading %s" % path) from None
            if not chunk:
                break
            out += chunk
            if progress is not None:
                progress(len(chunk))
        if len(out) != size:
            raise BoardError("%s: read %d bytes of %d (the file changed while it was read?)" % (path, len(out), size))
        import hashlib

        want = self.hashes([path])[path]
        if want != hashlib.sha256(out).hexdigest():
            raise HashMismatch("hash mismatch reading %s: a noisy cable? copy again" % path)
        return bytes(out)

    def remove(self, paths: Iterable[str], dirs: Iterable[str] = ()) -> None:
        """Remove files, then the folders in ``dirs`` that became empty."""
        paths, dirs = list(paths), list(dirs)
        if paths or dirs:
            self.exec("_rf_remove(%r, %r)" % (paths, dirs), "removing files")

    def identity(self) -> dict:
        """Which MicroPython build the board runs: ``platform``, ``machine``
        and ``version`` (``os.uname()``), ``release``, ``build``
        (``sys.implementation._build``, the board folder it was built for)."""
        return self._json("_u = os.uname()\nprint(json.dumps({'platform': sys.platform, 'machine': _u.machine, "
                          "'version': _u.version, 'release': _u.release, "
                          "'build': getattr(sys.implementation, '_build', None)}))\ndel _u",
                          "reading its build")

    def bootloader(self) -> None:
        """Restart the board into its boot ROM's BOOTSEL mode (the USB
        drive), as ``mpremote bootloader`` does; the port then goes away."""
        t = self._t
        if t is None:
            raise ConnectionLost("not connected to %s" % self.device)
        try:
            t.exec_raw_no_follow("import time, machine; time.sleep_ms(100); machine.bootloader()")
        except (TransportError, serial.SerialException, OSError) as exc:
            raise ConnectionLost("connection to %s lost while asking for BOOTSEL: %s" % (self.device, exc)) from None
        self._restarted = True

    # -------------------------------------------------------------- restart
    def restart(self, expect: str, timeout_s: float = 10.0, settle_s: float = 1.0) -> dict:
        """Soft-reset the board and watch the application start.

        MicroPython runs ``boot.py`` and ``main.py`` after a soft reset from
        the friendly REPL. The application's first line must be ``expect``
        (:mod:`.buildinfo`). Returns ``{"banner", "state", "output"}`` where
        state is ``running`` (quiet for ``settle_s`` after its banner),
        ``exited`` (back at the REPL prompt) or ``crashed`` (a traceback);
        raises :class:`AppDidNotStart` when no start-up line, or another
        one, came within ``timeout_s``.
        """
        t = self._t
        if t is None:
            raise ConnectionLost("not connected to %s" % self.device)
        ser = t.serial
        try:
            t.exit_raw_repl()
            t.read_until(1, b">>> ", timeout=self.timeout_s)
            ser.write(b"\x04")
            self._restarted = True
            ser.timeout = 0.05
            buf = b""
            start = last = time.monotonic()
            banner_seen = None
            while True:
                now = time.monotonic()
                chunk = ser.read(max(1, ser.in_waiting))
                if chunk:
                    buf += chunk
                    last = now
                text = buf.decode(errors="replace").replace("\r", "")
                after = text.split("soft reboot\n", 1)[1] if "soft reboot\n" in text else None
                if after is not None:
                    lines = after.split("\n")
                    if banner_seen is None:
                        banner_seen = next((ln for ln in lines[:-1] if buildinfo.BANNER_RE.match(ln)), None)
                    if after.endswith("\n>>> ") or after == ">>> ":
                        break
                    if banner_seen is not None and now - last >= settle_s:
                        break
                if now - start >= timeout_s:
                    break
        except (TransportError, serial.SerialException, OSError) as exc:
            raise ConnectionLost("connection to the board on %s lost while restarting it: %s" % (self.device, exc)) from None
        output = _app_output(after or "")
        crashed = "Traceback (most recent call last)" in (after or "")
        last_line = output.splitlines()[-1] if output else "no output"
        if banner_seen is None:
            raise AppDidNotStart("the application did not start: %s" % (
                last_line if after is not None else "the board did not reset within %g s" % timeout_s))
        if banner_seen != expect:
            raise AppDidNotStart("the board started '%s', not this build's '%s' (files not ours on the board?)"
                                 % (banner_seen, expect))
        if crashed:
            raise AppDidNotStart("the application started (%s) and then crashed: %s" % (banner_seen, last_line))
        state = "exited" if after is not None and after.rstrip(" ").endswith(">>>") else "running"
        return {"banner": banner_seen, "state": state, "output": output}


def _app_output(after: str) -> str:
    """The application's output, without the REPL's banner and prompt."""
    lines = after.split("\n")
    while lines and (lines[-1].strip() in ("", ">>>") or lines[-1].startswith("MicroPython v")
                     or lines[-1].startswith("Type \"help()\"")):
        lines.pop()
    return "\n".join(lines[-40:])
