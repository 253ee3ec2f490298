"""The twin's radio: the vehicle's UART bytes to a person's ground station.

The firmware's radio UART is emulated byte by byte (``board/machine.py``,
paced at its baud rate); these classes carry the bytes beyond it, as a SiK
radio pair would, so ``roboray-ground`` (or MAVProxy, QGroundControl)
connects to the simulated vehicle exactly as to the real one:

- ``PtyRadio``: a pseudo-terminal; ``device`` (``/dev/pts/N``) is what the
  ground station opens (``roboray-ground watch --master /dev/pts/N``);
- ``UdpRadio``: UDP, as ArduPilot's SITL does it: the vehicle sends to
  ``HOST:PORT`` (default 127.0.0.1) where the ground station listens
  (``--master udp:PORT``), and answers go back to the port the vehicle
  sent from;
- ``TcpRadio``: TCP, as SITL's ``tcp:5760``: the vehicle listens on
  ``PORT`` (127.0.0.1 unless ``tcp:HOST:PORT`` names the address to
  listen on) and serves one ground station at a time
  (``--master tcp:127.0.0.1:PORT``); closing it at the end of the run is
  what the ground station sees as the link closed.

All are non-blocking: ``read()`` returns what is there (possibly nothing),
``write(data)`` drops what the other side cannot take, as a radio drops
bytes nobody receives. ``parse_radio("pty" | "udp:PORT" | "udp:HOST:PORT" |
"tcp:PORT" | "tcp:HOST:PORT")`` makes one.
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
        self.describe = "udp %s:%d (connect with: roboray-ground watch --master udp:%d)" % (host, port, port)

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


class TcpRadio:
    """The vehicle's end of a TCP link: a listening port, one ground station
    connected at a time (a later one waits until it leaves)."""

    def __init__(self, port: int, host: str = "127.0.0.1") -> None:
        if not 0 < port < 65536:
            raise ValueError("--radio tcp: port %r outside 1..65535" % port)
        self._listen = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listen.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._listen.bind((host, port))
        except OSError as exc:
            self._listen.close()
            if exc.errno == errno.EADDRINUSE:
                raise OSError(exc.errno, "port %d is in use: another program listens there" % port)
            raise
        self._listen.listen(1)
        self._listen.setblocking(False)
        self._client: Optional[socket.socket] = None
        self.describe = "tcp %s:%d (connect with: roboray-ground watch --master tcp:%s:%d)" % (
            host, port, "127.0.0.1" if host == "0.0.0.0" else host, port)

    def _accept(self) -> None:
        if self._client is not None:
            return
        try:
            client, _ = self._listen.accept()
        except (BlockingIOError, InterruptedError):
            return
        client.setblocking(False)
        client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._client = client

    def _drop(self) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None

    def read(self) -> bytes:
        self._accept()
        out = b""
        while self._client is not None:
            try:
                chunk = self._client.recv(65536)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:          # reset by the ground station
                self._drop()
                break
            if not chunk:            # it left: the port is free for the next one
                self._drop()
                break
            out += chunk
        return out

    def write(self, data: bytes) -> None:
        self._accept()
        if not data or self._client is None:
            return
        try:
            self._client.send(data)
        except (BlockingIOError, InterruptedError):
            pass  # the ground station reads slower than the line: the bytes are lost
        except OSError:
            self._drop()

    def close(self) -> None:
        self._drop()
        self._listen.close()


def parse_radio(text: Optional[str]):
    """``None``, ``"pty"``, ``"udp:PORT"``, ``"udp:HOST:PORT"``, ``"tcp:PORT"``
    or ``"tcp:HOST:PORT"`` -> a radio or None."""
    if text is None or text == "none":
        return None
    if text == "pty":
        return PtyRadio()
    parts = text.split(":")
    if parts[0] in ("udp", "tcp") and len(parts) in (2, 3) and all(parts[1:]):
        try:
            port = int(parts[-1])
        except ValueError:
            raise ValueError("--radio %r: the port must be a number" % text)
        if parts[0] == "udp":
            return UdpRadio(port, parts[1] if len(parts) == 3 else "127.0.0.1")
        return TcpRadio(port, parts[1] if len(parts) == 3 else "127.0.0.1")
    raise ValueError("--radio %r: expected pty, udp:PORT, udp:HOST:PORT, tcp:PORT or tcp:HOST:PORT" % text)
