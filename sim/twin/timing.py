"""The board's time in the twin, host side: what to charge, and the loop's figures.

``board/boardtime.py`` (inside the interpreter) charges the board's compute
time to the virtual clock and records every task call, collection and slot;
this module chooses its settings (``config``) and turns the records the
lockstep sends with each frame into the loop's figures (``BoardTimes``):
per task mean, p99 and max a call, slot p50/p99/max, the longest
collection, flash stalls.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import numpy as np

#: Record kinds past the tasks (``board/boardtime.py``).
GC = 16
SLOT = 17
FLASH = 18
#: The per-task costs calibrated on the emulated RP2350
#: (``roboray-sim bench board --write-model``).
MODEL_PATH = Path(__file__).with_name("board_time_model.json")
REF_MHZ = 150.0


def load_model(path: Path = MODEL_PATH) -> dict:
    """The calibrated model; ``FileNotFoundError`` names the command that writes it."""
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise FileNotFoundError("no board time model at %s: roboray-sim bench board --write-model writes it" % path)


def write_model(model: dict, partial: bool = False, path: Path = MODEL_PATH) -> Path:
    """Write the model (``partial``: merge ``model`` into the one there)."""
    if partial and path.exists():
        merged = json.loads(path.read_text())
        merged.update(model)
        model = merged
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(model, indent=1, sort_keys=True) + "\n")
    tmp.replace(path)
    return path


def config(interpreter: str, board_time: str, cpu_mhz: float, model: Optional[dict] = None) -> Optional[dict]:
    """``lockstep.run``'s ``board_time`` for an interpreter: None when code is
    free (``free``); ``auto`` (the twin's default) counts instructions on the
    emulated RP2350 and charges the model calibrated there on the other
    interpreters, ``model`` charges it everywhere; ``model`` (the argument)
    instead of the calibrated one."""
    if board_time == "free":
        return None
    if model is not None:
        return {"source": "model", "cpu_mhz": cpu_mhz, "model": {"tasks": model["tasks"], "gc_us": model["gc_us"]}}
    model = load_model()
    if interpreter == "rp2350-emu" and board_time == "auto":
        return {"source": "emu", "cpu_mhz": cpu_mhz, "ps_per_insn": round(model["calibration"]["ps_per_insn"])}
    return {"source": "model", "cpu_mhz": cpu_mhz,
            "model": {"tasks": model["tasks"], "gc_us": model["gc_us"]}}


class BoardTimes:
    """The board's records, gathered frame by frame."""

    def __init__(self) -> None:
        self._chunks: list[np.ndarray] = []

    def add(self, hex_records: str) -> None:
        self._chunks.append(np.frombuffer(bytes.fromhex(hex_records), dtype="<i4"))

    def records(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(kind, mode, us) of every record so far."""
        if not self._chunks:
            z = np.zeros(0, dtype=np.int32)
            return z, z, z
        r = np.concatenate(self._chunks)
        return r >> 24, (r >> 21) & 7, r & 0x1FFFFF

    def summary(self, names: list, period_us: int = 10000) -> dict:
        """The loop's figures: per task and per slot, in us and ms."""
        kind, _, us = self.records()
        tasks = {}
        for i, name in enumerate(names):
            tasks[name] = _stats(us[kind == i])
        slots = us[kind == SLOT]
        # the slot's own collection, or the application's "gc" task
        gcs = us[kind == GC] if (kind == GC).any() or "gc" not in names else us[kind == names.index("gc")]
        flash = us[kind == FLASH]
        out = {"tasks": tasks, "gc": _stats(gcs), "slots": int(len(slots))}
        # the slots without a collection or a flash stall: the loop's own work
        quiet = _quiet_slots(kind, us, names)
        if len(quiet):
            out["slot_p99_ms_no_stall"] = round(float(np.percentile(quiet, 99)) / 1000.0, 3)
            out["slot_max_ms_no_stall"] = round(float(quiet.max()) / 1000.0, 3)
        if len(slots):
            out.update({
                "slot_p50_ms": round(float(np.percentile(slots, 50)) / 1000.0, 3),
                "slot_p99_ms": round(float(np.percentile(slots, 99)) / 1000.0, 3),
                "slot_max_ms": round(float(slots.max()) / 1000.0, 3),
                "slot_mean_ms": round(float(slots.mean()) / 1000.0, 3),
                "load_pct": round(100.0 * float(slots.mean()) / period_us, 1),
            })
        out["gc_ms_max"] = round(float(gcs.max()) / 1000.0, 3) if len(gcs) else None
        out["flash_stalls"] = int(len(flash))
        out["flash_stall_ms"] = round(float(flash.sum()) / 1000.0, 1) if len(flash) else 0.0
        return out


def _quiet_slots(kind: np.ndarray, us: np.ndarray, names: list) -> np.ndarray:
    """The SLOT records of slots that ran neither the "gc" task nor a flash
    stall (a slot's records end with its SLOT record)."""
    gc_kind = names.index("gc") if "gc" in names else GC
    keep = []
    stalled = False
    for k, u in zip(kind.tolist(), us.tolist()):
        if k == SLOT:
            if not stalled:
                keep.append(u)
            stalled = False
        elif k == gc_kind or k == FLASH or k == GC:
            stalled = True
    return np.asarray(keep)


def _stats(us: np.ndarray) -> dict:
    if len(us) == 0:
        return {"calls": 0}
    return {"calls": int(len(us)), "mean_us": round(float(us.mean()), 1),
            "p99_us": round(float(np.percentile(us, 99)), 1), "max_us": int(us.max())}
