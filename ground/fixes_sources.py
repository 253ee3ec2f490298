"""Where fixes come from: a serial port, TCP or UDP, as lines with their arrival time.

``SOURCE`` is written as pymavlink writes links:

- ``/dev/ttyUSB1`` or ``/dev/ttyUSB1,BAUD``: a serial port (pyserial),
  4800 baud unless given (NMEA 0183's rate);
- ``tcp:HOST:PORT``: we connect to a server that streams (Water Linked's
  NMEA bridge, a tracker's TCP output);
- ``tcpin:[HOST:]PORT``: we listen and the tracker connects to us, one at a
  time;
- ``udpin:[HOST:]PORT`` (or ``udp:``): we listen for datagrams, each one
  line or several.

A thread reads and stamps each line with the time it arrived
(``time.monotonic()`` and ``time.time()`` together, taken as the bytes
come), so the relay's own pace never ages a fix. Opening fails at once with
one line saying what to check (``SourceError``); a connection or a serial
port lost later is tried again every second, the line shown meanwhile in
``state``. A line over ``MAX_LINE`` bytes without an end is cut off and
reported as too long, so a source sending garbage cannot grow memory.
"""

from __future__ import annotations

import errno
import queue
import socket
import threading
import time
from typing import NamedTuple, Optional

from roboray.tools.cli import CliError

NMEA_BAUD = 4800
MAX_LINE = 4096
RETRY_S = 1.0
_POLL_S = 0.2


class SourceError(CliError):
    """A source that cannot be opened; one line, exit status 1."""


class Spec(NamedTuple):
    kind: str           #: "serial", "tcp", "tcpin" or "udpin"
    text: str           #: as the user wrote it
    path: str = ""
    baud: int = NMEA_BAUD
    host: str = ""
    port: int = 0


class Line(NamedTuple):
    mono: float         #: time.monotonic() when it arrived
    unix: float         #: time.time() then
    text: str           #: the line without its ending; "" with ``too_long``
    too_long: bool = False


def parse_source(text: str) -> Spec:
    """The source ``text`` names; ValueError says what is wrong."""
    scheme, colon, rest = text.partition(":")
    if colon and scheme in ("tcp", "tcpin", "udpin", "udp"):
        host, _, port_text = rest.rpartition(":")
        if scheme == "tcp" and not host:
            raise ValueError("%r: tcp needs HOST:PORT (the server to connect to)" % text)
        try:
            port = int(port_text)
        except ValueError:
            raise ValueError("%r: the port %r is not a number" % (text, port_text))
        if not 0 < port < 65536:
            raise ValueError("%r: port %d outside 1..65535" % (text, port))
        return Spec("udpin" if scheme == "udp" else scheme, text, host=host or "0.0.0.0", port=port)
    if colon and len(scheme) > 1 and "/" not in scheme:
        raise ValueError("%r: a serial port (PATH or PATH,BAUD), tcp:HOST:PORT, tcpin:[HOST:]PORT or "
                         "udpin:[HOST:]PORT" % text)
    path, comma, baud_text = text.partition(",")
    if not path:
        raise ValueError("%r: an empty serial port" % text)
    baud = NMEA_BAUD
    if comma:
        try:
            baud = int(baud_text)
        except ValueError:
            baud = 0
        if baud <= 0:
            raise ValueError("%r: the baud rate %r is not a whole number > 0" % (text, baud_text))
    return Spec("serial", text, path=path, baud=baud)


class Source:
    """Reads ``spec`` in a thread, putting each ``Line`` into the queue ``lines``."""

    def __init__(self, spec: Spec, lines: "queue.Queue[Line]") -> None:
        self.spec = spec
        self.lines = lines
        #: What is happening, for the status line ("ok", "waiting for ...", "lost: ... retrying").
        self.state = "opening"
        #: Times the connection or port was lost.
        self.losses = 0
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None
        self._conn: object = None        # the open socket or serial port
        self._listener: Optional[socket.socket] = None
        self._buf = bytearray()
        self._skipping = False

    def describe(self) -> str:
        s = self.spec
        return "%s at %d baud" % (s.path, s.baud) if s.kind == "serial" else s.text

    # ------------------------------------------------------------ open
    def open(self) -> None:
        """Open now, in the caller's thread; SourceError saying what to check."""
        s = self.spec
        if s.kind == "serial":
            self._conn = self._open_serial()
            self.state = "ok"
        elif s.kind == "tcp":
            self._conn = self._connect()
            self.state = "ok"
        elif s.kind == "udpin":
            self._conn = self._listen()
            self.state = "ok"
        else:
            self._listener = self._listen()
            self.state = "waiting for the tracker to connect to port %d" % s.port

    def _listen(self) -> socket.socket:
        s = self.spec
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM if s.kind == "udpin" else socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((s.host, s.port))
            if s.kind == "tcpin":
                sock.listen(1)
        except OSError as exc:
            sock.close()
            if exc.errno == errno.EADDRINUSE:
                raise SourceError("source %s: the address is in use (another program listens on port %d)"
                                  % (s.text, s.port))
            raise SourceError("source %s: cannot listen on %s:%d: %s" % (s.text, s.host, s.port,
                                                                         exc.strerror or exc))
        sock.settimeout(_POLL_S)
        return sock

    def _open_serial(self):
        import serial

        s = self.spec
        try:
            return serial.Serial(s.path, s.baud, timeout=_POLL_S, exclusive=True)
        except (serial.SerialException, OSError, ValueError) as exc:
            text = str(exc)
            code = getattr(exc, "errno", None)
            if code == errno.ENOENT or "No such file" in text:
                why = "no such port: is it plugged in? (roboray-ground ports lists them)"
            elif code in (errno.EACCES, errno.EPERM) or "Permission denied" in text:
                why = "permission denied: add your user to the dialout group (then log in again)"
            elif code == errno.EBUSY or "lock" in text or "busy" in text.lower():
                why = "busy: another program has it open"
            else:
                why = text.splitlines()[0] if text else type(exc).__name__
            raise SourceError("source %s: %s" % (s.path, why))

    def _connect(self) -> socket.socket:
        s = self.spec
        try:
            sock = socket.create_connection((s.host, s.port), timeout=3.0)
        except ConnectionRefusedError:
            raise SourceError("source %s: connection refused: is the tracker serving on port %d?" % (s.text, s.port))
        except socket.gaierror as exc:
            raise SourceError("source %s: no such host %s (%s)" % (s.text, s.host, exc.strerror or exc))
        except (socket.timeout, TimeoutError):
            raise SourceError("source %s: no answer within 3 s: is %s reachable?" % (s.text, s.host))
        except OSError as exc:
            raise SourceError("source %s: %s" % (s.text, exc.strerror or exc))
        sock.settimeout(_POLL_S)
        return sock

    # ------------------------------------------------------------ read
    def start(self) -> "Source":
        self._thread = threading.Thread(target=self._run, name="fix source", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self._drop()
        if self._listener is not None:
            self._listener.close()
            self._listener = None

    def _drop(self) -> None:
        conn, self._conn = self._conn, None
        if conn is not None:
            try:
                conn.close()    # type: ignore[attr-defined]
            except Exception:   # noqa: BLE001 - closing what already broke
                pass
        self._buf.clear()
        self._skipping = False

    def _run(self) -> None:
        while not self._stop.is_set():
            if self._conn is None and not self._reopen():
                self._stop.wait(RETRY_S)
                continue
            try:
                data = self._read()
            except OSError as exc:      # pyserial's SerialException is one too
                self._lost(str(exc) or type(exc).__name__)
                continue
            if data is None:
                self._lost("closed by the other end")
                continue
            if data:
                self._feed(data, time.monotonic(), time.time())

    def _reopen(self) -> bool:
        s = self.spec
        if s.kind == "tcpin":
            try:
                conn, peer = self._listener.accept()    # type: ignore[union-attr]
            except (socket.timeout, TimeoutError):
                return False
            except OSError:
                return False
            conn.settimeout(_POLL_S)
            self._conn = conn
            self.state = "ok (tracker at %s:%d)" % peer[:2]
            return True
        try:
            if s.kind == "serial":
                self._conn = self._open_serial()
            elif s.kind == "tcp":
                self._conn = self._connect()
            else:
                self._conn = self._listen()
        except SourceError:
            return False
        self.state = "ok"
        return True

    def _read(self) -> Optional[bytes]:
        """What arrived (b"" after the poll time), None when the other end closed."""
        conn = self._conn
        if self.spec.kind == "serial":
            data = conn.read(max(1, conn.in_waiting))    # type: ignore[attr-defined]
            return data
        try:
            if self.spec.kind == "udpin":
                data, _ = conn.recvfrom(65536)    # type: ignore[attr-defined]
                return data + (b"" if data.endswith(b"\n") else b"\n")   # a datagram ends its line
            data = conn.recv(65536)    # type: ignore[attr-defined]
        except (socket.timeout, TimeoutError):
            return b""
        return data if data else None

    def _lost(self, why: str) -> None:
        self._drop()
        if self._stop.is_set():
            return
        self.losses += 1
        if self.spec.kind == "tcpin":
            self.state = "the tracker went (%s): waiting for it to connect again" % why
        else:
            self.state = "lost (%s): retrying every %g s" % (why, RETRY_S)

    def _feed(self, data: bytes, mono: float, unix: float) -> None:
        buf = self._buf
        buf += data
        while True:
            end = buf.find(b"\n")
            if end < 0:
                if len(buf) > MAX_LINE:
                    if not self._skipping:
                        self.lines.put(Line(mono, unix, "", True))
                    self._skipping = True
                    buf.clear()
                return
            raw = bytes(buf[:end]).rstrip(b"\r")
            del buf[:end + 1]
            if self._skipping:      # the end of a line already reported too long
                self._skipping = False
                continue
            if len(raw) > MAX_LINE:
                self.lines.put(Line(mono, unix, "", True))
                continue
            self.lines.put(Line(mono, unix, raw.decode("utf-8", "replace")))
