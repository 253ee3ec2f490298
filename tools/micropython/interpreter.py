"""A real MicroPython interpreter, driven from CPython.

``MicroPython`` starts the WebAssembly port under Node.js (``host.mjs`` in
exec mode) and talks to it over pipes with one JSON document a line. Tests,
benchmarks and the software-in-the-loop twin use it to run the board code
exactly as it is, not a CPython imitation of it.

Values cross the boundary as JSON: lists, tuples and ``array``s arrive as
lists, ``bytes`` as ``bytes``, non-finite floats survive.
"""

from __future__ import annotations

import base64
import importlib
import json
import os
import select
import subprocess
import time
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

from .install import host_script, interpreter_module, node_executable, variant_wasm

#: Board packages copied into the interpreter, as (package, path on board).
BOARD_PACKAGES = ("roboray.shared", "roboray.firmware")
BOARD_LIB = "/lib"

# Defined once in the interpreter: turns a result into JSON-able data.
_PRELUDE = """
import json as __json
from array import array as __array
def __plain(o):
    t = type(o)
    if t is float:
        if o != o or o in (float('inf'), float('-inf')):
            return {'__float__': repr(o)}
        return o
    if t in (list, tuple, __array):
        return [__plain(x) for x in o]
    if t is dict:
        return {str(k): __plain(v) for k, v in o.items()}
    if t in (bytes, bytearray, memoryview):
        return {'__bytes__': bytes(o).hex()}
    return o
__result = None
__a0 = 0
__a1 = 0
__alloc = 0
"""


def wait_readable(fd: int, spin_s: float, timeout_s: Optional[float]) -> bool:
    """Wait until ``fd`` has data: poll for up to ``spin_s``, then sleep in
    ``select`` for up to ``timeout_s`` (None: for ever); False on time-out.

    Polling first, because a process asleep on a pipe costs the one that
    wakes it: on this machine Node's write of a hostlink request took
    ~100 us when we were asleep in select, ~15-25 us when we were polling
    (``roboray-sim bench sil``: the board's hostlink time per frame fell
    from 105-280 us to 65-85 us). ``sched_yield`` between polls gives the
    core away whenever anything else could use it.
    """
    if spin_s > 0:
        end = time.perf_counter() + spin_s
        while True:
            if select.select([fd], [], [], 0)[0]:
                return True
            if time.perf_counter() >= end:
                break
            os.sched_yield()
    return bool(select.select([fd], [], [], timeout_s)[0])


class MicroPythonError(Exception):
    """Code raised inside MicroPython; ``traceback`` is MicroPython's own text."""

    def __init__(self, traceback: str, output: str = "") -> None:
        self.traceback = traceback.rstrip()
        self.output = output
        last = self.traceback.splitlines()[-1] if self.traceback else ""
        #: Exception class name as MicroPython printed it, e.g. ``ValueError``.
        self.type_name = last.split(":", 1)[0].strip()
        super().__init__(self.traceback)


class InterpreterDied(RuntimeError):
    """The Node.js process running MicroPython ended or stopped answering."""


def _decode(o: Any) -> Any:
    if isinstance(o, list):
        return [_decode(x) for x in o]
    if isinstance(o, dict):
        if set(o) == {"__float__"}:
            return float(o["__float__"])
        if set(o) == {"__bytes__"}:
            return bytes.fromhex(o["__bytes__"])
        return {k: _decode(v) for k, v in o.items()}
    return o


def board_sources() -> list[tuple[Path, str]]:
    """Every board ``.py`` file as (host path, path on the board)."""
    files = []
    for package in BOARD_PACKAGES:
        root = Path(importlib.import_module(package).__path__[0])
        dest = BOARD_LIB + "/" + package.replace(".", "/")
        for path in sorted(root.rglob("*.py")):
            if "__pycache__" in path.parts:
                continue
            files.append((path, dest + "/" + path.relative_to(root).as_posix()))
    return files


class MicroPython:
    """One MicroPython interpreter in a Node.js child process.

    Parameters
    ----------
    heap_bytes:
        MicroPython heap size. Boards have 200-500 kB; the default leaves room
        for the whole firmware plus the test harness.
    on_request:
        Called with the text of every ``hostlink.request(text)`` made by code
        running in the interpreter; its return value (a str) is sent as an
        answer, None sends nothing. ``request`` returns the next answer not
        yet read, so a host may answer ahead: ``exec(code, replies=[...])``
        sends answers before the code runs, and then each answer sent after
        request k is the one request k+1 reads (the twin's pipeline).
    timeout_s:
        Longest wait for one request before the interpreter is declared dead.
    variant:
        None for the plain build; ``"settrace"`` for the build with
        ``sys.settrace`` (``tools/micropython/linecount.py``).
    spin_s:
        How long to poll for the interpreter's next message before sleeping
        until it comes (0: sleep at once). Settable; the twin polls while
        the board runs a frame (see ``wait_readable``).
    """

    def __init__(
        self,
        heap_bytes: int = 8 * 1024 * 1024,
        on_request: Optional[Callable[[str], Optional[str]]] = None,
        timeout_s: float = 120.0,
        variant: Optional[str] = None,
        spin_s: float = 0.0,
    ) -> None:
        self.on_request = on_request
        self.timeout_s = timeout_s
        self.spin_s = spin_s
        self._next_id = 0
        self._proc = subprocess.Popen(
            [node_executable(), str(host_script()), "exec", str(interpreter_module()), str(heap_bytes)]
            + ([str(variant_wasm(variant))] if variant else []),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            # its own session: a terminal's Ctrl-C reaches the host, which
            # stops a twin at a frame boundary (sim/twin/runner.py); the
            # interpreter ends when its stdin closes
            start_new_session=True,
        )
        self._buf = b""
        ready = self._read_message()
        if ready.get("op") != "ready":
            raise InterpreterDied("MicroPython host did not start: %r" % ready)
        self.version = ready.get("version")
        self.exec(_PRELUDE)

    # ----------------------------------------------------------- transport
    def _read_message(self) -> dict:
        assert self._proc.stdout is not None
        fd = self._proc.stdout.fileno()
        while b"\n" not in self._buf:
            ready = wait_readable(fd, self.spin_s, self.timeout_s)
            chunk = os.read(fd, 1 << 16) if ready else b""
            if not chunk:
                err = self._proc.stderr.read().decode(errors="replace") if self._proc.poll() is not None and self._proc.stderr else ""
                self.close()
                raise InterpreterDied(
                    "MicroPython host %s: %s"
                    % ("timed out" if not ready else "exited", err.strip()[-2000:] or "no message")
                )
            self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        return json.loads(line)

    def _send(self, msg: dict) -> None:
        assert self._proc.stdin is not None
        self._proc.stdin.write(json.dumps(msg).encode() + b"\n")
        self._proc.stdin.flush()

    def _request(self, msg: dict, replies: Sequence[str] = ()) -> dict:
        if self._proc.poll() is not None:
            raise InterpreterDied("MicroPython host is not running")
        self._next_id += 1
        msg["id"] = self._next_id
        self._send(msg)
        for answer in replies:
            self._send({"op": "reply", "data": answer})
        while True:
            reply = self._read_message()
            if reply.get("op") == "request":
                if self.on_request is None:
                    answer = ""
                else:
                    answer = self.on_request(reply["data"])
                if answer is not None:
                    self._send({"op": "reply", "data": answer})
                continue
            if reply.get("op") == "done" and reply.get("id") == msg["id"]:
                return reply

    # ------------------------------------------------------------- running
    def exec(self, code: str, replies: Sequence[str] = ()) -> str:
        """Run statements; return what they printed. Raises MicroPythonError.

        ``replies``: answers for the first ``hostlink.request`` calls, sent
        with the code (see ``on_request``)."""
        reply = self._request({"op": "exec", "code": code}, replies)
        self.last_us = reply.get("us", 0.0)
        #: The last exec's hostlink requests: ``requests``, and the wall time
        #: they spent sending (``send_us``) and then blocked until their
        #: answer was there (``wait_us``), measured by the host.
        self.last_hostlink = reply.get("hostlink") or {"requests": 0, "send_us": 0.0, "wait_us": 0.0}
        if not reply["ok"]:
            if reply.get("python"):
                raise MicroPythonError(reply["error"], reply.get("out", ""))
            raise InterpreterDied(reply["error"])
        return reply.get("out", "")

    def eval(self, expr: str) -> Any:
        """Value of one expression, converted to plain Python data."""
        self.exec("__result = __json.dumps(__plain(%s))" % expr)
        reply = self._request({"op": "global", "name": "__result"})
        return _decode(json.loads(reply["value"]))

    def call(self, target: str, *args: Any) -> Any:
        """Call ``"package.module:function"`` with JSON-able arguments."""
        module, func = target.split(":")
        self.exec("import %s" % module)
        return self.eval("%s.%s(*__json.loads(%r))" % (module, func, json.dumps(list(args))))

    # ---------------------------------------------------------- measuring
    def alloc_bytes(self, call: str, setup: str = "") -> int:
        """Heap bytes that one execution of ``call`` allocates.

        ``setup`` runs first (build the objects), then ``call`` once as a
        warm-up (first calls intern names and fill caches), then once more
        between two ``gc.mem_alloc()`` readings with the collector disabled,
        so a collection cannot hide an allocation.
        """
        if setup:
            self.exec(setup)
        self.exec(call)
        self.exec(
            "import gc\ngc.collect()\ngc.disable()\n__a0 = gc.mem_alloc()\n%s\n"
            "__a1 = gc.mem_alloc()\ngc.enable()\n__alloc = __a1 - __a0" % call
        )
        return int(self.eval("__alloc"))

    def time_us(self, call: str, setup: str = "", repeat: int = 100) -> float:
        """Mean wall time of ``call`` in microseconds on this interpreter."""
        if setup:
            self.exec(setup)
        self.exec(call)
        self.exec(
            "import time\n__t0 = time.ticks_us()\nfor __i in range(%d):\n    %s\n"
            "__result = time.ticks_diff(time.ticks_us(), __t0)" % (repeat, call)
        )
        return float(self.eval("__result")) / repeat

    # --------------------------------------------------------- file system
    def write_file(self, path: str, data: bytes | str) -> None:
        if isinstance(data, str):
            data = data.encode()
        reply = self._request({"op": "write", "path": path, "b64": base64.b64encode(data).decode()})
        if not reply["ok"]:
            raise OSError("cannot write %s in MicroPython: %s" % (path, reply["error"]))

    def read_file(self, path: str) -> bytes:
        reply = self._request({"op": "read", "path": path})
        if not reply["ok"]:
            raise FileNotFoundError("no %s in MicroPython's file system" % path)
        return base64.b64decode(reply["b64"])

    def install_board_code(self, compiled: bool = False) -> list[str]:
        """Copy shared/ and firmware/ to /lib/roboray/... as on a flashed board:
        as source, or ``compiled`` to ``.mpy`` as a build does (``mpycache``)."""
        return self.install_files(board_sources(), compiled)

    def install_files(self, files: Sequence[tuple[Path, str]], compiled: bool = False) -> list[str]:
        """Write (host ``.py``, board path) pairs; ``compiled``: their ``.mpy``."""
        from .mpycache import compiled as mpy

        written = []
        for host_path, board_path in files:
            if compiled:
                dest = board_path[:-3] + ".mpy"
                self.write_file(dest, mpy(host_path, board_path))
            else:
                dest = board_path
                self.write_file(dest, host_path.read_bytes())
            written.append(dest)
        return written

    # ----------------------------------------------------------- lifetime
    def close(self) -> None:
        proc = self._proc
        if proc.poll() is None:
            try:
                if proc.stdin:
                    proc.stdin.close()
                proc.wait(timeout=5)
            except (OSError, subprocess.TimeoutExpired):
                proc.kill()
                proc.wait()
        for stream in (proc.stdout, proc.stderr):
            if stream:
                stream.close()

    def __enter__(self) -> "MicroPython":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

