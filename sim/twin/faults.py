"""Faults the twin injects at a given time: ``--fault NAME[:ARG]@SECONDS``.

==========================  ==========================================================
name                        what happens
==========================  ==========================================================
``depth-nack``              the MS5837 stops answering (every transfer a NACK)
``depth-garbage``           it answers with noise
``depth-stick``             its conversions freeze at their present values
``imu-nack|garbage|stick``  the same for the LSM6DSOX (accelerometer, gyroscope)
``mag-nack|garbage|stick``  the same for the LIS3MDL
``depth-ok``, ``imu-ok``,   the part is healthy again
``mag-ok``
``radio-loss``              nothing crosses the radio link, either way
``radio-corrupt[:P]``       each byte on the link has one bit flipped with
                            probability P (default 0.05), both ways
``radio-ok``                the link is clean again
``battery-sag[:V]``         the pack falls towards V volts (default 6.2) in about a
                            second: a failing cell
``leak``                    water at the leak probe
``powercut[:N]``            the power goes, and the board comes back on: at once
                            (N 0, the default), or the operator changes a
                            parameter (FS_GCS_TIMEOUT + 1 s) and the power goes
                            at the N-th flash step of the save that follows (a
                            save has ``save_steps()``, 6: a larger N is refused;
                            armed and moving, the save waits for the vehicle to
                            be disarmed or at rest, and so does the cut)
``watchdog``                the loop hangs; the watchdog resets the board
``stall[:MS]``              the chip is busy once for MS milliseconds (default 150,
                            a flash save's announced stall) without telling the loop:
                            the slots it spans are missed and every sensor's last
                            sample is that old when the loop comes back
``overload[:US]``           every clock reading costs US microseconds (default 400):
                            the loop overruns; one heavy enough that it overruns 25
                            slots in a row (overload:3000 does) starves the watchdog,
                            which resets the board (and ends the overload)
==========================  ==========================================================

``parse(text)`` checks a fault and returns a ``Fault``; a bad one is a
``ValueError`` that names what is wrong and what is allowed.
``check_times(faults, duration_s)`` refuses a fault timed at or after the
run's end, which would never happen.
"""

from __future__ import annotations

import functools
import math
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

SENSORS = ("depth", "imu", "mag")
#: Sensor fault kinds: ``board/i2c_device.py``'s FAULT_* numbers.
SENSOR_KINDS = {"ok": 0, "nack": 1, "garbage": 2, "stick": 3}
NAMES = tuple("%s-%s" % (s, k) for s in SENSORS for k in SENSOR_KINDS) + (
    "radio-loss", "radio-corrupt", "radio-ok", "battery-sag", "leak", "powercut", "watchdog", "stall", "overload")
#: Faults that take an argument, with its default.
DEFAULTS = {"radio-corrupt": 0.05, "battery-sag": 6.2, "powercut": 0, "stall": 150, "overload": 400}


@dataclass(frozen=True)
class Fault:
    name: str
    at_s: float
    arg: Optional[float] = None

    def __str__(self) -> str:
        arg = "" if self.arg is None or self.name not in DEFAULTS else ":%g" % self.arg
        return "%s%s@%g" % (self.name, arg, self.at_s)


def parse(text: str) -> Fault:
    """``NAME[:ARG]@SECONDS`` -> ``Fault``; ValueError naming the problem."""
    if "@" not in text:
        raise ValueError("fault %r: expected NAME@SECONDS, e.g. depth-nack@20" % text)
    head, when = text.rsplit("@", 1)
    try:
        at = float(when)
    except ValueError:
        raise ValueError("fault %r: %r is not a time in seconds" % (text, when))
    if not math.isfinite(at) or at < 0:
        raise ValueError("fault %r: the time must be a finite number of seconds >= 0" % text)
    name, _, arg_text = head.partition(":")
    if name not in NAMES:
        raise ValueError("fault %r: unknown fault %r; known: %s" % (text, name, ", ".join(NAMES)))
    arg: Optional[float] = None
    if arg_text:
        if name not in DEFAULTS:
            raise ValueError("fault %r: %s takes no argument" % (text, name))
        try:
            arg = float(arg_text)
        except ValueError:
            raise ValueError("fault %r: argument %r is not a number" % (text, arg_text))
        if not math.isfinite(arg):
            raise ValueError("fault %r: argument must be finite" % text)
        if name == "radio-corrupt" and not 0.0 <= arg <= 1.0:
            raise ValueError("fault %r: the corruption probability must be within 0..1" % text)
        if name == "battery-sag" and not 0.0 <= arg <= 20.0:
            raise ValueError("fault %r: the pack voltage must be within 0..20 V" % text)
        if name in ("powercut", "stall", "overload") and (arg < 1 or arg != int(arg)):
            raise ValueError("fault %r: %s needs a whole number >= 1" % (text, name))
        if name == "stall" and not 1 <= arg <= 900:
            raise ValueError("fault %r: a stall of 1..900 ms (the watchdog bites at 1 s)" % text)
        if name == "powercut" and arg > save_steps():
            raise ValueError("fault %r: a parameter save has %d flash steps, so the power cannot go at "
                             "step %d; use 1..%d" % (text, save_steps(), int(arg), save_steps()))
    elif name in DEFAULTS:
        arg = float(DEFAULTS[name])
    return Fault(name, at, arg)


@functools.lru_cache(maxsize=1)
def save_steps() -> int:
    """The flash steps of a parameter save (``powercut``'s N counts them), as
    the firmware's own ``ParamStore`` takes them: counted by running it on
    ``board/powercut.py``'s ``PowerCutFiles`` (``cut_at=0`` counts and never
    cuts), with the backup a save replaces already there."""
    from roboray.firmware import app
    from roboray.firmware.param_store import Files, ParamStore
    from roboray.shared.params import ParamTable
    from roboray.sim.twin.board.powercut import PowerCutFiles

    with tempfile.TemporaryDirectory(prefix="roboray-steps-") as d:
        files = PowerCutFiles(Files(), 0)
        store = ParamStore(ParamTable(app.PARAMS), str(Path(d) / "params.bin"), files)
        store.save()
        store.save()        # from here on a backup exists: a save's every step
        before = files.steps
        store.save()
        return files.steps - before


def check_times(faults: list, duration_s: float) -> None:
    """ValueError for a fault timed at or after the run's end."""
    for f in faults:
        if f.at_s >= duration_s:
            raise ValueError("fault %s: at %g s, but the run ends at %g s (the scenario's duration or "
                             "--duration)" % (f, f.at_s, duration_s))
