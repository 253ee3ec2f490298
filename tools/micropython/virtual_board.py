"""A virtual MicroPython board behind a pseudo-terminal.

Host tools (pyserial, mpremote, the flashing tool) open the pseudo-terminal's
device path as they would ``/dev/ttyACM0``. Behind it runs the WebAssembly
port in REPL mode (``host.mjs repl``); this module carries the bytes and
mends, at the byte stream, the three ways the port differs from a board:

- raw-paste (``Ctrl-E A Ctrl-A`` in the raw REPL) is mishandled: we answer
  ``R\\x00`` ("not supported") ourselves, so the host falls back to the plain
  raw REPL;
- a soft reset (Ctrl-D) is left to the host: ``host.mjs`` re-initialises the
  VM on the same file system and prints ``MPY: soft reboot`` as a board does;
- file errors carry Emscripten's errno numbers (``OSError: 44``): we rewrite
  them to the numbers and names a board prints (``[Errno 2] ENOENT``).

It also behaves like a board where a host tool relies on it:

- Ctrl-C interrupts a running program (``main.py``'s loop), so tools reach
  the REPL as on a board: every Ctrl-C also goes down a side pipe that the
  interpreter polls whenever the program reads its clock (``host.mjs``);
- ``os.statvfs`` reports a flash of ``flash_bytes`` (a Pico 2's 3 MiB by
  default) and what the files use of it, so free-space checks mean something;
- ``modules`` offers modules the way firmware has them built in (the
  twin's emulated ``machine``): importable, first on ``sys.path``, but
  outside the board's visible and synced file system (``/home/roboray``).

And it can fail as a board's flash can: ``bad_writes=(prefix, n)`` stores
the first ``n`` writes to files under ``prefix`` with a bit flipped, for
testing that a host tool reads back what it wrote.

The file system is a host folder (``fs_dir``), mirrored after every input
chunk, so it survives a restart of the virtual board like flash does.
"""

from __future__ import annotations

import json
import os
import re
import select
import shutil
import subprocess
import tempfile
import threading
import time
import tty
from pathlib import Path
from typing import Iterable, Optional

from .install import host_script, interpreter_module, node_executable

#: Emscripten errno -> (MicroPython errno, name), for the errors a file system raises.
EMSCRIPTEN_ERRNO = {
    63: (1, "EPERM"), 44: (2, "ENOENT"), 29: (5, "EIO"), 8: (9, "EBADF"),
    6: (11, "EAGAIN"), 48: (12, "ENOMEM"), 2: (13, "EACCES"), 10: (16, "EBUSY"),
    20: (17, "EEXIST"), 43: (19, "ENODEV"), 54: (20, "ENOTDIR"), 31: (21, "EISDIR"),
    28: (22, "EINVAL"), 51: (28, "ENOSPC"), 69: (30, "EROFS"), 55: (39, "ENOTEMPTY"),
    73: (110, "ETIMEDOUT"), 138: (95, "EOPNOTSUPP"),
}

#: Flash a Pico 2 (RPI_PICO2) gives its file system: 4 MiB less 1 MiB of firmware.
PICO2_FLASH_BYTES = 3 * 1024 * 1024

_RAW_PASTE_REQUEST = b"\x05A\x01"
_RAW_PASTE_UNSUPPORTED = b"R\x00"
_OSERROR = re.compile(rb"OSError: (\d+)(?=\r?\n)")
_HOLD = re.compile(rb"O(S(E(r(r(o(r(:( \d*)?)?)?)?)?)?)?)?\r?$")


def twin_builtins() -> list[Path]:
    """The twin's emulated built-in modules (its ``machine.py``), if it exists.

    The simulator twin (``sim/twin/``) writes MicroPython code standing in for
    the firmware's built-in ``machine``; the virtual board offers it with
    ``modules`` so a deployed application finds ``machine`` as on a bare
    Pico 2 (an I2C bus where nothing answers). Empty while there is none.
    """
    import importlib.util

    spec = importlib.util.find_spec("roboray.sim")
    if spec is None or not spec.submodule_search_locations:
        return []
    twin = Path(list(spec.submodule_search_locations)[0]) / "twin"
    found = sorted(p for p in twin.rglob("machine.py") if "__pycache__" not in p.parts) if twin.is_dir() else []
    return found[:1]


def _board_errno(match: "re.Match[bytes]") -> bytes:
    code = int(match.group(1))
    if code in EMSCRIPTEN_ERRNO:
        num, name = EMSCRIPTEN_ERRNO[code]
        return b"OSError: [Errno %d] %s" % (num, name.encode())
    return match.group(0)


class VirtualBoard:
    """Run ``with VirtualBoard() as board: serial.Serial(board.device)``.

    Parameters
    ----------
    fs_dir:
        Host folder holding the board's file system. A temporary folder,
        removed on close, when not given.
    flash_bytes:
        Capacity ``os.statvfs('/')`` reports; None keeps the interpreter's
        own (meaningless) figures.
    modules:
        Host ``.py`` files offered like built-in modules, by their names.
    bad_writes:
        ``(path_prefix, n)``: the first ``n`` writes to files whose board
        path starts with ``path_prefix`` are stored with a bit flipped.
    """

    def __init__(
        self,
        fs_dir: Optional[os.PathLike | str] = None,
        heap_bytes: int = 8 * 1024 * 1024,
        flash_bytes: Optional[int] = PICO2_FLASH_BYTES,
        modules: Iterable[os.PathLike | str] = (),
        bad_writes: Optional[tuple[str, int]] = None,
    ) -> None:
        if flash_bytes is not None and flash_bytes < 16 * 4096:
            raise ValueError("flash_bytes must be at least 64 KiB, got %r" % flash_bytes)
        self.modules = [Path(m).resolve() for m in modules]
        for m in self.modules:
            if m.suffix != ".py" or not m.is_file():
                raise ValueError("modules: %s is not a .py file" % m)
        self._own_dir = fs_dir is None
        self.fs_dir = Path(fs_dir) if fs_dir is not None else Path(tempfile.mkdtemp(prefix="roboray-board-"))
        self.fs_dir.mkdir(parents=True, exist_ok=True)
        self.heap_bytes = heap_bytes
        self.flash_bytes = flash_bytes
        self.bad_writes = bad_writes
        self._intr_r, self._intr_w = os.pipe()
        os.set_blocking(self._intr_r, False)
        os.set_blocking(self._intr_w, False)
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        #: Path host tools open, like /dev/ttyACM0.
        self.device = os.ttyname(self._slave)
        self._proc: Optional[subprocess.Popen] = None
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._raw = False
        self._in_pending = b""
        self._out_pending = b""
        self._out_since = 0.0
        self._lock = threading.Lock()

    # -------------------------------------------------------------- lifetime
    def start(self) -> "VirtualBoard":
        options: dict = {"interrupt_fd": self._intr_r}
        if self.flash_bytes is not None:
            options["flash_bytes"] = self.flash_bytes
        if self.modules:
            options["modules"] = [str(m) for m in self.modules]
        if self.bad_writes is not None:
            options["bad_writes"] = [str(self.bad_writes[0]), int(self.bad_writes[1])]
        self._proc = subprocess.Popen(
            [node_executable(), str(host_script()), "repl", str(interpreter_module()),
             str(self.fs_dir), str(self.heap_bytes), json.dumps(options)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, bufsize=0,
            pass_fds=(self._intr_r,),
        )
        os.close(self._intr_r)
        self._intr_r = -1
        for target in (self._pump_in, self._pump_out):
            t = threading.Thread(target=target, daemon=True)
            t.start()
            self._threads.append(t)
        return self

    def close(self) -> None:
        self._stop.set()
        proc = self._proc
        if proc is not None and proc.poll() is None:
            try:
                assert proc.stdin is not None
                proc.stdin.close()  # host.mjs syncs the file system and exits
                proc.wait(timeout=10)
            except (OSError, subprocess.TimeoutExpired):
                proc.kill()
                proc.wait()
        for t in self._threads:
            t.join(timeout=2)
        for fd in (self._master, self._slave, self._intr_r, self._intr_w):
            try:
                os.close(fd)
            except OSError:
                pass
        if self._own_dir:
            shutil.rmtree(self.fs_dir, ignore_errors=True)

    def wait(self) -> int:
        """Block until the interpreter process ends; its exit status."""
        assert self._proc is not None
        return self._proc.wait()

    @property
    def alive(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    def __enter__(self) -> "VirtualBoard":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------ host -> MP
    def _pump_in(self) -> None:
        assert self._proc is not None and self._proc.stdin is not None
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.1)
            if not ready:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                return
            forward = self._filter_input(data)
            if forward:
                try:
                    self._proc.stdin.write(forward)
                except (BrokenPipeError, ValueError):
                    return

    def _filter_input(self, data: bytes) -> bytes:
        data = self._in_pending + data
        self._in_pending = b""
        out = bytearray()
        i = 0
        while i < len(data):
            c = data[i]
            if self._raw and c == 0x05:
                tail = data[i:i + 3]
                if tail == _RAW_PASTE_REQUEST:
                    self._write_master(_RAW_PASTE_UNSUPPORTED)
                    i += 3
                    continue
                if _RAW_PASTE_REQUEST.startswith(tail):  # split across reads
                    self._in_pending = tail
                    break
            if c == 0x03:
                # Before the byte itself reaches stdin: the interpreter drops
                # signals that arrive while it is idle (host.mjs).
                try:
                    os.write(self._intr_w, b"\x03")
                except OSError:
                    pass
            elif c == 0x01:
                self._raw = True
            elif c == 0x02:
                self._raw = False
            out.append(c)
            i += 1
        return bytes(out)

    # ------------------------------------------------------------ MP -> host
    def _pump_out(self) -> None:
        assert self._proc is not None and self._proc.stdout is not None
        fd = self._proc.stdout.fileno()
        while True:
            ready, _, _ = select.select([fd], [], [], 0.02)
            if not ready:
                if self._out_pending and time.monotonic() - self._out_since > 0.05:
                    self._flush_output(final=True)
                if self._stop.is_set() and self._proc.poll() is not None:
                    return
                continue
            data = os.read(fd, 4096)
            if not data:
                self._flush_output(final=True)
                return
            if not self._out_pending:
                self._out_since = time.monotonic()
            self._out_pending += data
            self._flush_output(final=False)

    def _flush_output(self, final: bool) -> None:
        buf = _OSERROR.sub(_board_errno, self._out_pending)
        hold = b""
        if not final:
            # Keep back a tail that could still become "OSError: <n>\r\n".
            m = _HOLD.search(buf[-16:])
            if m:
                cut = len(buf) - 16 + m.start() if len(buf) > 16 else m.start()
                buf, hold = buf[:cut], buf[cut:]
        self._out_pending = hold
        if buf:
            self._write_master(buf)

    def _write_master(self, data: bytes) -> None:
        with self._lock:
            view = memoryview(data)
            while view:
                try:
                    n = os.write(self._master, view)
                except BlockingIOError:
                    time.sleep(0.001)
                    continue
                except OSError:
                    return
                view = view[n:]
