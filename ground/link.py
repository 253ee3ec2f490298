"""The ground station's MAVLink link to the vehicle, on pymavlink.

Connection strings are MAVProxy's ``--master`` forms (``parse_master``
turns them into pymavlink's): a serial path (``/dev/ttyUSB0``, or
``/dev/ttyUSB0,57600``); ``udp:PORT``, ``udpin:PORT`` or
``udpin:HOST:PORT`` (listen, on 0.0.0.0 when no host is given);
``udpout:HOST:PORT``; ``tcp:HOST:PORT`` (``tcpout:`` alike; a bare port is
this machine's, where ArduPilot's SITL and the twin's ``--radio tcp:PORT``
listen); ``tcpin:PORT`` or ``tcpin:HOST:PORT`` (wait for the vehicle to
connect). Every failure a user can cause becomes a ``LinkError`` (a
``CliError``, exit 1) with one line saying what to check; a malformed
string is a ``UsageError`` (exit 2).

The link closing under a command is ``LinkClosed`` (exit 3, ``EXIT_CLOSED``):
a serial port that went away (a USB radio unplugged, the twin's
pseudo-terminal closed at the end of its run) or a TCP connection the
vehicle's end closed. pymavlink would print "Device ... is dead" or "EOF on
TCP socket" on stdout and carry on reading nothing; ``Link`` takes its
writes and its TCP end-of-file hooks itself, so nothing of pymavlink's
reaches the user's terminal. A listening link (``udpin``, ``tcpin``)
never closes: a vehicle that goes silent is a lost link, shown as such
(``watch``), and may come back.

Signing: ``--key PASSPHRASE`` derives the 32-byte key as MAVProxy's
``signing setup`` does (SHA-256 of the passphrase); we sign what we send and
pymavlink refuses what the vehicle sends unsigned or badly signed.

Our signing clock follows the vehicle's (docs/design/signing.md): before our
first frame we listen up to ``SYNC_S`` for a frame the vehicle signed with
our key and sign from its timestamp. After a reset the vehicle's clock
restarts up to two minutes ahead of the wall clock, and the twin's starts
years behind it; stamped with the wall clock, our first frames would be
refused (too old for a new stream, or far-future) and counted as attacks.
pymavlink itself only moves its clock up, and only on frames whose
timestamps it takes (a new stream more than a minute older than its clock
is refused), so we read the timestamp ourselves: signature checked with our
key, timestamp taken as it is. A vehicle whose clock was never set (under
2**24 units) takes ours instead; when nothing signed with our key comes
within ``SYNC_S`` we send anyway (wrong key, no key on the vehicle). After
``RESYNC_AFTER_S`` without a frame signed with our key (the vehicle went
silent: it may have restarted) we listen again before the next frame.
``change_key`` sends SETUP_SIGNING (``roboray-ground signing setup`` and
``signing remove``) and confirms it took.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import io
import logging
import math
import os
import socket
import time
from typing import Any, Callable, Optional

from roboray.shared import modes as vehicle_modes
from roboray.tools.cli import CliError, UsageError

log = logging.getLogger("roboray.ground")

DEFAULT_BAUD = 57600
#: Our component id: a ground control station (MAV_COMP_ID_MISSIONPLANNER).
GCS_COMPONENT = 190

#: Before our first frame, listen this long (s) for the vehicle's signing clock.
SYNC_S = 1.5
#: Without a frame signed with our key for this long (s), listen again first.
RESYNC_AFTER_S = 3.0
_UNIX_2015 = 1420070400     # signing timestamps count 10 us units from 2015-01-01 UTC
_CLOCK_SET = 1 << 24        # a vehicle clock below this (168 s past 2015) was never set

RESULTS = {
    0: "accepted", 1: "temporarily rejected", 2: "denied", 3: "unsupported",
    4: "failed", 5: "in progress", 6: "cancelled",
}


#: The exit status of a command whose link closed under it (``LinkClosed``).
EXIT_CLOSED = 3


class LinkError(CliError):
    """A link failure the user can fix; one line, exit status 1."""


class LinkClosed(CliError):
    """The vehicle's end of the link went away while a command used it: a
    serial port gone, a TCP connection closed. Exit status ``EXIT_CLOSED``.
    Not a ``LinkError``: a command that retries or waits over link errors
    (``watch`` shows a silent link as lost) must not wait on a port that
    is gone."""

    exit_code = EXIT_CLOSED


#: MAVProxy's network forms: the prefix, pymavlink's prefix, whether it
#: listens (a missing host is then 0.0.0.0, else this machine).
_NETWORK = {"udp": ("udpin", True), "udpin": ("udpin", True), "udpout": ("udpout", False),
            "tcp": ("tcp", False), "tcpout": ("tcp", False), "tcpin": ("tcpin", True)}


def parse_master(text: str) -> str:
    """A ``--master`` string as pymavlink opens it (see the module docstring);
    ``UsageError`` naming what is wrong. Serial paths pass unchanged."""
    text = text.strip()
    kind, sep, rest = text.partition(":")
    if not sep or kind.lower() not in _NETWORK:
        if not text:
            raise UsageError("--master: empty: a serial port, udp:PORT, tcp:HOST:PORT, ... or auto")
        return text
    prefix, listens = _NETWORK[kind.lower()]
    parts = rest.split(":")
    forms = "%s:PORT or %s:HOST:PORT" % (kind, kind)
    if len(parts) == 1:
        host, port_text = ("0.0.0.0" if listens else "127.0.0.1"), parts[0]
    elif len(parts) == 2:
        host, port_text = parts
    else:
        raise UsageError("--master %s: expected %s" % (text, forms))
    if not host:
        raise UsageError("--master %s: no host before the port (expected %s)" % (text, forms))
    try:
        port = int(port_text)
    except ValueError:
        port = -1
    if not 0 < port < 65536:
        raise UsageError("--master %s: %r is not a port (1 to 65535; expected %s)" % (text, port_text, forms))
    if prefix == "udpout" and len(parts) == 1:
        raise UsageError("--master %s: udpout sends to a host: expected udpout:HOST:PORT" % text)
    return "%s:%s:%d" % (prefix, host, port)


def key_from_passphrase(passphrase: str) -> bytes:
    """MAVProxy's ``signing setup PASSPHRASE``: SHA-256 of the passphrase."""
    return hashlib.sha256(passphrase.encode()).digest()


def read_key_file(path: str) -> str:
    """The passphrase on the first line of a key file."""
    with open(path, encoding="utf-8") as f:
        line = f.readline().strip()
    if not line:
        raise LinkError("key file %s is empty: put the signing passphrase on its first line" % path)
    return line


def signing_now() -> int:
    """The wall clock as a signing timestamp: 10 us units since 2015-01-01 UTC."""
    return int((max(time.time(), _UNIX_2015) - _UNIX_2015) * 100000)


def signed_timestamp(frame: bytes, key: bytes) -> Optional[int]:
    """The timestamp of a MAVLink 2 ``frame`` signed with ``key``; None when it
    is not signed or its signature does not match (the timestamp unjudged)."""
    if len(frame) < 25 or frame[0] != 0xFD or not frame[2] & 1:
        return None
    if hashlib.sha256(key + bytes(frame[:-6])).digest()[:6] != bytes(frame[-6:]):
        return None
    return int.from_bytes(bytes(frame[-12:-6]), "little")


def _signed(frame: bytes) -> bool:
    return len(frame) > 2 and frame[0] == 0xFD and bool(frame[2] & 1)


def _is_serial(master: str) -> bool:
    return ":" not in master.split(",")[0] and not master.endswith(".tlog")


def _connect_error(master: str, exc: BaseException, timeout: float) -> LinkError:
    """One line for a TCP connection that could not be made."""
    host = master.split(":")[1]
    if isinstance(exc, socket.gaierror):
        return LinkError("cannot connect to %s: no such host %s" % (master, host))
    if isinstance(exc, ConnectionRefusedError) or getattr(exc, "errno", None) == errno.ECONNREFUSED:
        return LinkError("cannot connect to %s: connection refused: nothing listens there (is the vehicle, "
                         "its bridge or the twin's --radio tcp:PORT running?)" % master)
    if isinstance(exc, (socket.timeout, TimeoutError)):
        return LinkError("cannot connect to %s: no answer within %g s: check the address and the network "
                         "(--timeout)" % (master, timeout))
    return LinkError("cannot connect to %s: %s" % (master, getattr(exc, "strerror", None) or exc))


def _open_error(master: str, exc: BaseException) -> LinkError:
    text = str(exc)
    code = getattr(exc, "errno", None)
    path = master.split(",")[0]
    if code == errno.ENOENT or "No such file" in text or "[Errno 2]" in text:
        return LinkError("no such port %s: is the radio plugged in? (roboray-ground ports lists them)" % path)
    if code in (errno.EACCES, errno.EPERM) or "Permission denied" in text or "[Errno 13]" in text:
        return LinkError("permission denied on %s: add your user to the dialout group (then log in again)" % path)
    if code == errno.EBUSY or "busy" in text.lower() or "[Errno 16]" in text:
        return LinkError("port %s is busy: another program (MAVProxy, a ground station) has it open" % path)
    if "Address already in use" in text:
        return LinkError("cannot listen on %s: the address is in use" % master)
    return LinkError("cannot open %s: %s" % (master, text.splitlines()[0] if text else type(exc).__name__))


class Link:
    """One connection to the vehicle.

    Parameters
    ----------
    master:
        pymavlink connection string.
    baud:
        Serial baud rate (ignored for network links; ``PATH,BAUD`` wins).
    source_system:
        Our MAVLink system id (255 like MAVProxy).
    key:
        32-byte signing key, or None.
    """

    def __init__(self, master: str, baud: int = DEFAULT_BAUD, source_system: int = 255,
                 key: Optional[bytes] = None, connect_timeout: float = 5.0) -> None:
        os.environ["MAVLINK20"] = "1"  # before pymavlink picks its dialect: MAVLink 2, signing
        from pymavlink import mavutil

        mavutil.set_dialect("common")
        if not log.isEnabledFor(logging.DEBUG):
            # pymavlink tells every signed stream it meets at INFO ("new stream"): not for the user
            logging.getLogger("pymavlink").setLevel(logging.WARNING)
        master = parse_master(master)
        self.master = master
        self.baud = baud
        if _is_serial(master) and "," in master:
            try:
                self.baud = int(master.split(",", 1)[1])
            except ValueError:
                raise LinkError("bad baud rate in %r: expected PATH,BAUD" % master)
        if _is_serial(master) and not os.path.exists(master.split(",")[0]):
            raise _open_error(master, FileNotFoundError(errno.ENOENT, "No such file"))
        said = io.StringIO()
        tcp = master.startswith("tcp:")
        old_timeout = socket.getdefaulttimeout()
        try:
            # One connection attempt (pymavlink retries a refused TCP
            # connection six times a second apart, printing each), bounded
            # by connect_timeout; what pymavlink prints is logged, not shown.
            if tcp:
                socket.setdefaulttimeout(connect_timeout)
            with contextlib.redirect_stdout(said):
                self.conn: Any = mavutil.mavlink_connection(
                    master, baud=self.baud, source_system=source_system,
                    source_component=GCS_COMPONENT, autoreconnect=False, retries=0)
        except Exception as exc:  # pyserial, socket and pymavlink errors
            if tcp and isinstance(exc, OSError):
                raise _connect_error(master, exc, connect_timeout) from exc
            raise _open_error(master, exc) from exc
        finally:
            socket.setdefaulttimeout(old_timeout)
            if said.getvalue():
                log.debug("pymavlink: %s", said.getvalue().strip())
        self._guard()
        self.mav = self.conn.mav
        self.mav.robust_parsing = True
        self.key: Optional[bytes] = None
        self.set_key(key)
        self.target_system = 1
        self.target_component = 1
        self.texts: list[str] = []
        self.vehicle_heartbeat: Any = None
        self.on_message: Optional[Callable[[Any], None]] = None
        self._last_gcs_hb = 0.0

    # ------------------------------------------------------ closed links
    def _closed(self, why: str, exc: Optional[BaseException] = None) -> LinkClosed:
        if exc is not None:
            log.debug("%s: %s", self.master, exc)
        where = self.master.split(",")[0]
        return LinkClosed("link closed: %s (%s)" % (why, where))

    def _guard(self) -> None:
        """Take over what pymavlink does when the vehicle's end goes away
        (see the module docstring): a failed write or read of a serial port,
        a TCP end-of-file or reset, become ``LinkClosed``."""
        from pymavlink import mavutil

        conn = self.conn
        if isinstance(conn, mavutil.mavserial):
            port = conn.port

            def write(buf: Any) -> int:
                try:
                    return port.write(bytes(buf))
                except Exception as exc:  # noqa: BLE001 - pyserial's SerialException, OSError
                    raise self._closed("the vehicle's port went away", exc) from exc

            conn.write = write
            serial_recv = conn.recv

            def recv(n: Optional[int] = None) -> Any:
                try:
                    return serial_recv(n)
                except Exception as exc:  # noqa: BLE001 - EIO: the other end of the line is gone
                    raise self._closed("the vehicle's port went away", exc) from exc

            conn.recv = recv
        elif isinstance(conn, mavutil.mavtcp):
            def gone() -> None:
                raise self._closed("the vehicle closed the TCP connection")

            conn.handle_eof = gone
            conn.handle_disconnect = gone
        elif isinstance(conn, mavutil.mavtcpin):
            conn.recv = self._tcpin_recv

    def _tcpin_recv(self, n: Optional[int] = None) -> Any:
        """pymavlink's ``mavtcpin.recv``, but a vehicle that disconnects
        frees the line for the next connection (pymavlink keeps the closed
        socket and reads its end-of-file in a busy loop)."""
        conn = self.conn
        if conn.port is None:
            try:
                conn.port, _ = conn.listen.accept()
            except OSError:
                return b""
            conn.port.setsockopt(socket.SOL_TCP, socket.TCP_NODELAY, 1)
            conn.port.setblocking(False)
            conn.fd = conn.port.fileno()
        try:
            data = conn.port.recv(n if n is not None else conn.mav.bytes_needed())
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:
            data = b""
        if not data:
            conn.port.close()
            conn.port = None
            conn.fd = conn.listen.fileno()
        return data

    # ----------------------------------------------------------- signing
    def set_key(self, key: Optional[bytes], timestamp: Optional[int] = None) -> None:
        """Sign with ``key`` from now on (None: unsigned), our clock at least
        ``timestamp``; we listen for the vehicle's clock again before sending."""
        sg = self.mav.signing
        self.key = key
        if key is None:
            sg.secret_key = None
            sg.sign_outgoing = False
        else:
            link_id = sg.link_id if sg.secret_key is not None else None   # the same link id on a new key
            self.conn.setup_signing(key, sign_outgoing=True, link_id=link_id)
            if timestamp is not None:
                sg.timestamp = max(sg.timestamp, timestamp)
        self._synced = key is None
        self._sync_end: Optional[float] = None
        self._heard = 0.0

    def _note_clock(self, m: Any) -> None:
        """Follow the vehicle's signing clock (see the module docstring)."""
        ts = signed_timestamp(m.get_msgbuf(), self.key)   # type: ignore[arg-type]
        if ts is None:
            return
        self._heard = time.monotonic()
        if not self._synced:
            self._synced = True
            if ts >= _CLOCK_SET:
                sg = self.mav.signing
                sg.timestamp = ts + 1
                log.debug("signing clock from the vehicle's: %d", ts)

    def may_send(self) -> bool:
        """Whether our clock follows the vehicle's (or we waited ``SYNC_S`` for it)."""
        if self.key is None:
            return True
        now = time.monotonic()
        if self._synced:
            if now - self._heard <= RESYNC_AFTER_S:
                return True
            self._synced = False   # silent: it may have restarted with its clock ahead
            self._sync_end = None
        if self._sync_end is None:
            self._sync_end = now + SYNC_S
        return now >= self._sync_end

    def ready(self) -> None:
        """Wait (reading) until ``may_send``."""
        while not self.may_send():
            self.recv(0.05)

    def vehicle_signs(self) -> bool:
        """Whether the vehicle's last heartbeat came signed."""
        hb = self.vehicle_heartbeat
        return hb is not None and _signed(hb.get_msgbuf())

    def change_key(self, key: Optional[bytes], timeout: float = 6.0, tries: int = 3) -> None:
        """SETUP_SIGNING (MAVProxy's ``signing setup``/``remove``): the vehicle
        signs with ``key`` from now on, None removes signing (an all-zero key).

        Sent signed with our current key (unsigned when we have none), with
        our wall clock as ``initial_timestamp``; then we take the new key and
        confirm: a PARAM_REQUEST_READ of SYSID_THISMAV is answered signed
        with the new key (pymavlink checks it), or, after a removal, an
        unsigned one is answered unsigned (a vehicle with a key would refuse
        it). Not confirmed, it is sent again with the old key. LinkError when
        it never took. Call after ``wait_heartbeat``."""
        old = self.key
        hb = self.vehicle_heartbeat
        if hb is not None and hb.base_mode & 128:   # MAV_MODE_FLAG_SAFETY_ARMED
            raise LinkError("the vehicle is armed: it takes a signing change only disarmed (roboray-ground disarm)")
        secret = list(key if key is not None else bytes(32))
        per_try = timeout / tries
        for attempt in range(tries):
            if attempt:
                self.set_key(old)
            self.ready()
            self.texts.clear()
            now = signing_now()
            self.mav.setup_signing_send(self.target_system, self.target_component, secret,
                                        now if key is not None else 0)
            self.set_key(key, now)
            if self._confirm(key, time.monotonic() + per_try):
                return
        said = [t for t in self.texts if "signing" in t]
        why = " (the vehicle said: %s)" % said[-1] if said else ""
        raise LinkError("%s not confirmed: no answer %s from %s within %g s%s" % (
            "signing setup" if key is not None else "signing remove",
            "signed with the new key" if key is not None else "unsigned", self.describe(), timeout, why))

    def _confirm(self, key: Optional[bytes], deadline: float) -> bool:
        self.ready()
        while time.monotonic() < deadline:
            self.mav.param_request_read_send(self.target_system, self.target_component, b"SYSID_THISMAV", -1)
            m = self.wait(lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == "SYSID_THISMAV",
                          min(0.5, max(0.01, deadline - time.monotonic())))
            if m is not None and _signed(m.get_msgbuf()) == (key is not None):
                return True
        return False

    # ------------------------------------------------------------ basics
    def describe(self) -> str:
        return "%s at %d baud" % (self.master, self.baud) if _is_serial(self.master) else self.master

    def close(self) -> None:
        try:
            self.conn.close()
        except Exception:  # noqa: BLE001 - closing a dead port
            pass

    def heartbeat(self, force: bool = False) -> None:
        """Our GCS heartbeat, at most once a second unless forced."""
        now = time.monotonic()
        if not self.may_send():
            return
        if force or now - self._last_gcs_hb >= 1.0:
            self._last_gcs_hb = now
            self.mav.heartbeat_send(6, 8, 0, 0, 0)  # MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID

    def recv(self, timeout: float) -> Any:
        """Next message (or None after ``timeout`` s); keeps our heartbeat going."""
        self.heartbeat()
        try:
            m = self.conn.recv_match(blocking=True, timeout=timeout)
        except OSError as exc:
            raise LinkError("lost %s: %s" % (self.describe(), exc)) from exc
        if m is not None and self.key is not None:
            self._note_clock(m)   # BAD_DATA too: pymavlink refuses a vehicle far behind its clock
        if m is None or m.get_type() == "BAD_DATA":
            return None
        if m.get_type() == "STATUSTEXT":
            self.texts.append(m.text)
        if self.on_message is not None:
            self.on_message(m)
        return m

    def wait_heartbeat(self, timeout: float = 5.0) -> Any:
        """The vehicle's heartbeat; sets the target ids. LinkError after ``timeout``."""
        end = time.monotonic() + timeout
        asked = False
        while time.monotonic() < end:
            if not asked and self.may_send():
                asked = True
                self.heartbeat(force=True)
                # ask for a heartbeat now rather than wait up to a second for the next one
                self.mav.command_long_send(0, 0, 512, 0, 0, 0, 0, 0, 0, 0, 0)  # MAV_CMD_REQUEST_MESSAGE
            m = self.recv(min(0.5 if asked else 0.05, max(0.01, end - time.monotonic())))
            if m is not None and m.get_type() == "HEARTBEAT" and m.type != 6:
                self.target_system = m.get_srcSystem()
                self.target_component = m.get_srcComponent()
                self.vehicle_heartbeat = m
                return m
        if _is_serial(self.master):
            hint = "check the radio is powered and paired, the baud rate (--baudrate)"
        else:
            hint = "check that the vehicle or its bridge sends to this address"
        if self.key is not None:
            hint += " and that the vehicle has the same signing key"
        raise LinkError("no heartbeat on %s within %g s: %s" % (self.describe(), timeout, hint))

    def wait(self, accept: Callable[[Any], bool], timeout: float) -> Any:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            m = self.recv(min(0.2, max(0.01, end - time.monotonic())))
            if m is not None and accept(m):
                return m
        return None

    # ---------------------------------------------------------- commands
    def command(self, command: int, params: tuple = (0, 0, 0, 0, 0, 0, 0), timeout: float = 3.0,
                retries: int = 3, name: str = "command") -> Any:
        """Send COMMAND_LONG until its COMMAND_ACK; LinkError when refused or silent."""
        p = list(params) + [0.0] * (7 - len(params))
        self.ready()
        self.texts.clear()
        for attempt in range(retries):
            self.mav.command_long_send(self.target_system, self.target_component, command, attempt, *p)
            ack = self.wait(lambda m: m.get_type() == "COMMAND_ACK" and m.command == command,
                            timeout / retries)
            if ack is not None:
                if ack.result != 0:
                    self.wait(lambda m: m.get_type() == "STATUSTEXT", 0.3)  # the reason follows the ack
                    why = self.reason(ack)
                    if why.startswith(name + " refused: "):   # the vehicle's text names the command too
                        why = why[len(name) + 10:]
                    raise LinkError("%s refused: %s (%s)" % (name, why, RESULTS.get(ack.result, ack.result)))
                return ack
        hint = "the vehicle may require signing (--key)" if self.key is None else "check the signing key"
        raise LinkError("no COMMAND_ACK for %s from %s within %g s: %s" % (name, self.describe(), timeout, hint))

    def reason(self, ack: Any) -> str:
        code = getattr(ack, "result_param2", 0)
        if 0 < code < len(vehicle_modes.REASONS):
            return vehicle_modes.REASONS[code]
        if self.texts:
            return self.texts[-1]
        return "no reason given"

    # -------------------------------------------------------- parameters
    def param_list(self, timeout: float = 10.0) -> dict[str, tuple[float, int]]:
        """Every parameter as name -> (value, MAV_PARAM_TYPE); missing ones re-read by index."""
        self.ready()
        self.mav.param_request_list_send(self.target_system, self.target_component)
        got: dict[int, tuple[str, float, int]] = {}
        count = -1
        end = time.monotonic() + timeout
        quiet_since = time.monotonic()
        while time.monotonic() < end:
            m = self.recv(0.2)
            if m is not None and m.get_type() == "PARAM_VALUE":
                count = m.param_count
                got[m.param_index] = (m.param_id, m.param_value, m.param_type)
                quiet_since = time.monotonic()
                if len(got) >= count:
                    break
            elif count > 0 and time.monotonic() - quiet_since > 0.5:
                for i in range(count):
                    if i not in got:
                        self.mav.param_request_read_send(self.target_system, self.target_component, b"", i)
                quiet_since = time.monotonic()
        if count < 0:
            raise LinkError("no parameters from %s within %g s" % (self.describe(), timeout))
        if len(got) < count:
            raise LinkError("got %d of %d parameters from %s within %g s" % (len(got), count, self.describe(), timeout))
        return {name: (value, ptype) for name, value, ptype in (got[i] for i in sorted(got))}

    def param_get(self, name: str, timeout: float = 3.0) -> tuple[float, int]:
        self.ready()
        for _ in range(3):
            self.mav.param_request_read_send(self.target_system, self.target_component, name.encode(), -1)
            m = self.wait(lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == name, timeout / 3)
            if m is not None:
                return m.param_value, m.param_type
        raise LinkError("no parameter %s on the vehicle (no answer within %g s)%s" % (name, timeout, self._unkeyed()))

    def _unkeyed(self) -> str:
        """Why a signing vehicle may ignore us: we have no key."""
        if self.key is None and self.vehicle_signs():
            return ": the vehicle signs its frames and refuses ours without its key (--key)"
        return ""

    def param_set(self, name: str, value: float, ptype: Optional[int] = None, timeout: float = 3.0) -> float:
        """Set and wait for the echo; LinkError with the vehicle's reason when refused."""
        if ptype is None:
            _, ptype = self.param_get(name)
        if not math.isfinite(value):
            raise LinkError("%s: %r is not a finite number" % (name, value))
        self.ready()
        self.texts.clear()
        for _ in range(3):
            self.mav.param_set_send(self.target_system, self.target_component, name.encode(), value, ptype)
            m = self.wait(lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == name, timeout / 3)
            if m is not None:
                if not _same_f32(m.param_value, value):
                    self.wait(lambda m: m.get_type() == "STATUSTEXT", 0.3)
                    why = self.texts[-1] if self.texts else "refused"
                    if why.startswith(name + ": "):
                        why = why[len(name) + 2:]
                    raise LinkError("%s not set to %s: %s (value stays %s)" % (name, fmt_value(value, ptype), why,
                                                                               fmt_value(m.param_value, ptype)))
                return m.param_value
        raise LinkError("no answer to setting %s within %g s" % (name, timeout))


def _same_f32(a: float, b: float) -> bool:
    import struct

    return struct.pack("<f", a) == struct.pack("<f", b)


def f32(value: float) -> float:
    """``value`` rounded to the nearest float32, the vehicle's precision."""
    import struct

    return struct.unpack("<f", struct.pack("<f", value))[0]


def fmt_value(value: float, ptype: int) -> str:
    """A parameter value as text that reads back to the same float32.

    Integer types without a decimal point; REAL32 as the shortest decimal
    that is the same float32 (``0.1``, not ``0.1000000015``), written as
    Python writes that number (``4.0``, ``101325.0``): a file saved and
    loaded again sets exactly the values it was saved from."""
    if ptype != 9 and float(value).is_integer():
        return "%d" % int(value)
    if not math.isfinite(value):
        return repr(value)
    want = f32(value)
    for digits in range(1, 10):     # 9 significant digits always identify a float32
        text = "%.*g" % (digits, want)
        if f32(float(text)) == want:
            return repr(float(text))
    return repr(want)
