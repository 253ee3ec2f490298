"""The twin's radio: the vehicle's UART bytes to a person's ground station.

The firmware's radio UART is emulated byte by byte (``board/machine.py``,
paced at its baud rate); these classes carry the bytes beyond it, as a SiK
radio pair would, so ``roboray-ground`` (or MAVProxy, QGroundControl)
connects to the simulated vehicle exactly as to the real one:

- ``PtyRadio``: a pseudo-terminal; ``device`` (``/dev/pts/N``) is what the
  ground station opens (``roboray-ground watch --master /dev/pts/N``);
- ``UdpRadio``: UDP, as ArduPilot's SITL does it: the vehicle sends to
  ``HOST:PORT`` (default 127.0.0.1) where the ground station listens
  (``--master udpin:0.0.0.0:PORT``), and answers go back to the port the
  vehicle sent from.

Both are non-blocking: ``read()`` returns what is there (possibly nothing),
``write(data)`` drops what the other side cannot take, as a radio drops
bytes nobody receives. ``parse_radio("pty" | "udp:PORT" | "udp:HOST:PORT")``
makes one.
"""

from __future__ import annotations

import errno
import os
import socket
import tty
from typing import Optional


class PtyRadio:
    """The ground end of the radio on a pseudo-terminal."""

    def __init__(self) -> None:
        self._master, self._slave = os.openpty()
        tty.setraw(self._master)
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self.device = os.ttyname(self._slave)
        self.describe = self.device

    def read(self) -> bytes:
        out = b""
        while True:
            try:
                chunk = os.read(self._master, 4096)
            except BlockingIOError:
                break
            except OSError:      # EIO: nobody holds the other end open
                break
            if not chunk:
                break
            out += chunk
        return out

    def write(self, data: bytes) -> None:
        if not data:
            return
        try:
            os.write(self._master, data)
        except OSError:
            pass  # the line's buffer is full or nobody listens: the bytes are lost

    def close(self) -> None:
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass


class UdpRadio:
    """The vehicle's end of a UDP link to a listening ground station."""

    def __init__(self, port: int, host: str = "127.0.0.1") -> None:
        if not 0 < port < 65536:
            raise ValueError("--radio udp: port %r outside 1..65535" % port)
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setblocking(False)
        self._sock.bind(("0.0.0.0", 0))
        self._to = (host, port)
        self.describe = "udp %s:%d (ground: --master udpin:0.0.0.0:%d)" % (host, port, port)

    def read(self) -> bytes:
        out = b""
        while True:
            try:
                data, _ = self._sock.recvfrom(65536)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as exc:   # ECONNREFUSED: nobody listens yet
                if exc.errno in (errno.ECONNREFUSED, errno.EAGAIN):
                    break
                raise
            out += data
        return out

    def write(self, data: bytes) -> None:
        if not data:
            return
        try:
            self._sock.sendto(data, self._to)
        except OSError:
            pass  # nobody listening yet

    def close(self) -> None:
        self._sock.close()


def parse_radio(text: Optional[str]):
    """``None``, ``"pty"``, ``"udp:PORT"`` or ``"udp:HOST:PORT"`` -> a radio or None."""
    if text is None or text == "none":
        return None
    if text == "pty":
        return PtyRadio()
    parts = text.split(":")
    if parts[0] == "udp" and len(parts) in (2, 3):
        try:
            port = int(parts[-1])
        except ValueError:
            raise ValueError("--radio %r: the port must be a number" % text)
        return UdpRadio(port, parts[1] if len(parts) == 3 else "127.0.0.1")
    raise ValueError("--radio %r: expected pty, udp:PORT or udp:HOST:PORT" % text)
