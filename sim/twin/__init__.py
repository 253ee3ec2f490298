"""The software-in-the-loop twin: the firmware, unchanged, on an emulated board.

``board/`` holds MicroPython code that runs inside the interpreter next to
the firmware (virtual clock, emulated ``machine``, register-level sensors);
this module puts it there:

- ``board_sources()``: the files, as (host path, path on the board), laid
  out under ``/lib/roboray/sim/twin/board/`` so the same import lines work
  on CPython and MicroPython;
- ``install(mp)``: copy them into a ``MicroPython`` interpreter;
- ``emulate(mp)``: install, then make the interpreter a board on the
  virtual clock: ``sys.modules['time']`` becomes ``vclock`` and
  ``sys.modules['machine']`` the emulated module, before any firmware is
  imported (``PRELUDE``);
- ``interpreter()``: a fresh ``MicroPython`` with the board code and the
  twin installed and ``PRELUDE`` run;
- ``reset(mp)``: back to a bare board at time 0 (``RESET``).

Wiring a twin, inside the interpreter (names from ``board/``)::

    t = machine.twin
    depth = t.attach(0, MS5837Device())       # I2C0, 0x76
    imu = t.attach(0, LSM6DSOXDevice())        # 0x6A
    mag = t.attach(0, LIS3MDLDevice())         # 0x1C
    vclock.set_hook(step)                      # step(dt_us): world, then devices
    # in step: depth.set(p_pa, temp_c); imu.set_accel(...); imu.set_gyro(...);
    # mag.set_field(...); t.set_adc_volts(0, v_batt / 3.0); t.set_pin(15, leak);
    # wings = [t.pulse_ns(p) for p in (10, 11, 12, 13)];
    # t.uart(0).feed(ground_bytes); sent = t.uart(0).take(); t.check_watchdog()

The same files run on CPython with ``vclock`` and ``machine`` put into
``sys.modules`` of a fresh process before the firmware is imported.

``MACHINE_PY`` is the emulated ``machine`` module alone, importable without
the rest, for a virtual board that needs a bare Pico 2.
"""

from __future__ import annotations

from pathlib import Path

BOARD_DIR = Path(__file__).with_name("board")
BOARD_DEST = "/lib/roboray/sim/twin/board"
MACHINE_PY = BOARD_DIR / "machine.py"

#: Run inside MicroPython before the firmware is imported.
PRELUDE = (
    "import sys\n"
    "from roboray.sim.twin.board import vclock\n"
    "sys.modules['time'] = vclock\n"
    "from roboray.sim.twin.board import machine\n"
    "sys.modules['machine'] = machine\n"
)


def board_sources() -> list[tuple[Path, str]]:
    """The twin's MicroPython files as (host path, path on the board)."""
    return [(p, BOARD_DEST + "/" + p.name) for p in sorted(BOARD_DIR.glob("*.py"))]


def install(mp, compiled: bool = False) -> list[str]:
    """Copy the twin's MicroPython files into interpreter ``mp`` (``compiled``: as ``.mpy``)."""
    return mp.install_files(board_sources(), compiled)


def emulate(mp, compiled: bool = False) -> None:
    """Install the twin into ``mp`` and switch its ``time`` and ``machine``."""
    install(mp, compiled)
    mp.exec(PRELUDE)


def interpreter(compiled: bool = True, **kwargs):
    """A new MicroPython with the board code and the emulated board in place:
    compiled to ``.mpy`` as a board boots it (``tools/micropython/mpycache.py``),
    or as source with ``compiled=False``."""
    from roboray.tools.micropython import MicroPython

    mp = MicroPython(**kwargs)
    try:
        mp.install_board_code(compiled)
        emulate(mp, compiled)
    except BaseException:
        mp.close()
        raise
    return mp


#: Run inside MicroPython to get a bare board again on a fresh clock.
RESET = (
    "machine.twin.clear()\n"
    "vclock.set_hook(None)\n"
    "vclock.set_tick_cost_us(0)\n"
    "vclock.reset()\n"
)


def reset(mp) -> None:
    """Back to a bare board at time 0 (devices detached, clock hook removed)."""
    mp.exec(RESET)
