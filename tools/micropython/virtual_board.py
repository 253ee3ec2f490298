"""A virtual MicroPython board behind a pseudo-terminal.

Host tools (pyserial, mpremote, the flashing tool) open the pseudo-terminal's
device path as they would ``/dev/ttyACM0``. Behind it runs the WebAssembly
port in REPL mode (``host.mjs repl``), and it answers as a Pico 2 does:

- the board's file system is at ``/`` (Emscripten's ``/tmp``, ``/home``,
  ``/dev`` and ``/proc`` are not), ``os.ilistdir`` gives littlefs's sizes,
  and ``os.statvfs`` reports a flash of ``flash_bytes`` (a Pico 2's 3 MiB by
  default) and what the files use of it, so free-space checks mean something;
- ``sys.platform``, ``sys.implementation``, ``sys.version``, ``os.uname()``
  and the REPL's banner name the rp2 port on a Pico 2 (``IDENTITY``);
- a running program reads the serial line through ``sys.stdin`` (mpremote's
  ``mount`` protocol does) and Ctrl-C interrupts it whenever it reads its
  clock or stdin, as the board's USB handler would (``host.mjs``);
- a soft reset (Ctrl-D, ``sys.exit()``) re-initialises the VM on the same
  file system and prints ``MPY: soft reboot``; ``machine.reset()`` restarts
  it silently into the friendly REPL, running ``main.py``;
- ``modules`` offers modules the way firmware has them built in (the
  twin's emulated ``machine``): imported at each start, from nowhere the
  board can list or copy.

The port's quirks are mended in ``host.mjs``, so this module only carries
bytes: raw-paste (``Ctrl-E A Ctrl-A``), which the port mishandles, is
declined with ``R\\x00``, so hosts use the plain raw REPL; file errors carry
a board's errno numbers (``OSError: [Errno 2] ENOENT``, not Emscripten's 44).

And it can fail as a board's flash can: ``bad_writes=(prefix, n)`` stores
the first ``n`` writes to files under ``prefix`` with a bit flipped, for
testing that a host tool reads back what it wrote.

The file system is a host folder (``fs_dir``), written back whenever the
board waits for input and at ``os.sync()``, so it survives a restart of the
virtual board like flash does.
"""

from __future__ import annotations

import json
import os
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

#: Flash a Pico 2 (RPI_PICO2) gives its file system: 4 MiB less 1 MiB of firmware.
PICO2_FLASH_BYTES = 3 * 1024 * 1024

#: What the rp2 port says it is on a Pico 2 (ports/rp2: MICROPY_PY_SYS_PLATFORM;
#: boards/RPI_PICO2: MICROPY_HW_BOARD_NAME "with" MICROPY_HW_MCU_NAME).
IDENTITY = {"platform": "rp2", "machine": "Raspberry Pi Pico2 with RP2350", "build": "RPI_PICO2"}


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
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        #: Path host tools open, like /dev/ttyACM0.
        self.device = os.ttyname(self._slave)
        self._proc: Optional[subprocess.Popen] = None
        self._in_w = -1
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._boots = 0
        self._booted = threading.Condition()
        #: What the interpreter's host said on stderr, other than its starts.
        self.messages: list[str] = []

    # -------------------------------------------------------------- lifetime
    def start(self) -> "VirtualBoard":
        # The serial input goes through a FIFO the interpreter holds twice: as
        # stdin, where the idle REPL waits, and without blocking, where a
        # running program looks for input (a pipe's one description cannot
        # be both).
        fifo_dir = tempfile.mkdtemp(prefix="roboray-board-in-")
        fifo = os.path.join(fifo_dir, "serial")
        os.mkfifo(fifo)
        try:
            nonblock_r = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
            self._in_w = os.open(fifo, os.O_WRONLY)
            block_r = os.open(fifo, os.O_RDONLY)
        finally:
            os.unlink(fifo)
            os.rmdir(fifo_dir)
        options: dict = {"nonblock_fd": nonblock_r, "identity": IDENTITY}
        if self.flash_bytes is not None:
            options["flash_bytes"] = self.flash_bytes
        if self.modules:
            options["modules"] = [str(m) for m in self.modules]
        if self.bad_writes is not None:
            options["bad_writes"] = [str(self.bad_writes[0]), int(self.bad_writes[1])]
        try:
            self._proc = subprocess.Popen(
                [node_executable(), str(host_script()), "repl", str(interpreter_module()),
                 str(self.fs_dir), str(self.heap_bytes), json.dumps(options)],
                stdin=block_r, stdout=subprocess.PIPE, stderr=subprocess.PIPE, bufsize=0,
                pass_fds=(nonblock_r,),
            )
        finally:
            os.close(nonblock_r)
            os.close(block_r)
        for target in (self._pump_in, self._pump_out, self._pump_err):
            t = threading.Thread(target=target, daemon=True)
            t.start()
            self._threads.append(t)
        return self

    def close(self) -> None:
        self._stop.set()
        proc = self._proc
        if self._threads:
            self._threads[0].join(timeout=1)  # the input pump: it writes to _in_w
        in_w, self._in_w = self._in_w, -1
        if in_w >= 0:
            os.close(in_w)  # the line hangs up: host.mjs syncs the file system and exits
        if proc is not None and proc.poll() is None:
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for t in self._threads:
            t.join(timeout=2)
        for fd in (self._master, self._slave):
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
    def boots(self) -> int:
        """Times the board has started as from power-on: 1 once it is up,
        one more after each ``machine.reset()``."""
        with self._booted:
            return self._boots

    def wait_for_boot(self, boots: int, timeout_s: float = 60.0) -> None:
        """Block until the board has started ``boots`` times, as a host waits
        for a Pico to enumerate again after ``machine.reset()`` (its USB is
        gone meanwhile; this pseudo-terminal stays open, so bytes sent before
        the board is back would race the reset: Ctrl-C could interrupt it, or
        the reset would drop them). ``TimeoutError`` if it does not come back."""
        with self._booted:
            if not self._booted.wait_for(lambda: self._boots >= boots or not self.alive, timeout_s):
                raise TimeoutError("the virtual board did not start %d time(s) in %.0f s (%d so far)"
                                   % (boots, timeout_s, self._boots))
            if self._boots < boots:
                raise TimeoutError("the virtual board's interpreter ended after %d start(s): %s"
                                   % (self._boots, " | ".join(self.messages[-3:])))

    @property
    def alive(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    def __enter__(self) -> "VirtualBoard":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------ host -> MP
    def _pump_in(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.1)
            if not ready:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                return
            view = memoryview(data)
            try:
                while view:
                    view = view[os.write(self._in_w, view):]
            except OSError:  # closed, or the interpreter has gone
                return

    def _pump_err(self) -> None:
        assert self._proc is not None and self._proc.stderr is not None
        for raw in iter(self._proc.stderr.readline, b""):
            line = raw.decode("utf-8", "replace").rstrip("\n")
            with self._booted:
                if line == "virtual board: up":
                    self._boots += 1
                else:
                    self.messages.append(line)
                self._booted.notify_all()
        with self._booted:
            self._booted.notify_all()  # ended: a waiter need not wait out its time

    # ------------------------------------------------------------ MP -> host
    def _pump_out(self) -> None:
        assert self._proc is not None and self._proc.stdout is not None
        fd = self._proc.stdout.fileno()
        while True:
            data = os.read(fd, 4096)
            if not data:
                return
            view = memoryview(data)
            while view:
                try:
                    view = view[os.write(self._master, view):]
                except BlockingIOError:
                    time.sleep(0.001)
                except OSError:
                    return
