"""``roboray-sim bench board``: the firmware's time on the emulated RP2350.

Every figure is counted on the emulated board (``tools/rp2350_emu/``:
QEMU, MicroPython for the Cortex-M33 with single-precision floats) and
turned into RP2350 microseconds by the calibration against published
Pico 2 timings (``tools/rp2350_emu/calibration.py``):

- ``tasks``: each task's mean, p99 and max a call, from the twin's
  target-landing on the emulated board (compute, I2C bus time and flash
  stalls charged to the virtual clock as the chip would spend them);
- ``slot_p50_ms``, ``slot_p99_ms``, ``slot_max_ms``: a slot's work
  including its collection and flash stalls; ``slot_p99_ms_no_flash``,
  ``slot_max_ms_no_flash``: with the collections, without the slots a
  flash write stalled; ``..._no_stall``: without either;
- ``gc_ms``: one ``gc.collect()`` at the firmware's live heap, the
  firmware built on the emulated board without the world, marked in the
  collector's order (``firmware/collector.py``; ``gc_order_objects``
  ordered in ``gc_order_prepare_ms`` at start-up); ``gc_ms_unordered``:
  the same heap before it is ordered (the mark stack overflows and the
  heap is scanned twice); ``gc_insns``, ``gc_insns_unordered``: their
  instructions; ``heap_live_bytes``, ``heap_size_bytes``;
- ``float_impl`` and ``word_bits`` as the board reports them, ``build``
  (``--build``: ``roboray``, RoboRay's MicroPython, the default, or
  ``stock``) and its ``obj_repr`` (``C``: floats in the object word, ``A``:
  boxed on the heap);
- ``flight_collections``: collections in the armed slots: the stock
  build's "gc" task, the firmware's ``collector.collect()`` inside a task
  (RoboRay's build: at rest, or on a low heap estimate) and the
  allocator's on a full heap;
  ``flight_alloc_bytes_per_slot``: the bytes the tasks of an armed slot
  allocate, mean over the armed slots (``sim/twin/board/boardtime.py``
  counts them around each task call, the emulated peripherals' own bytes
  left out; the twin's garbage is collected off the board's time while
  the firmware's bytes fit a Pico 2's free heap);
- ``calibration``: the published figures, their sources, the cost of an
  instruction and its uncertainty, counted on the stock build (the
  published timings were all measured on stock builds) and applied to the
  build that flies.

``--write-model`` writes the per-task, per-mode costs the default twin
charges (``sim/twin/board_time_model.json``) from runs of target-landing
and velocity.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from roboray.tools.cli import CliError, add_json, command, emit

#: Firmware built on the emulated board without the world: the live heap
#: and one collection. ``emuboard.insns`` around ``gc.collect()``.
_GC_PROBE = """
import gc, sys, json, emuboard
gc.collect()
base = gc.mem_alloc()
%(prelude)s
from roboray.sim.twin.board import vclock
from roboray.sim.twin.board.ms5837_device import MS5837Device
from roboray.sim.twin.board.lsm6dsox_device import LSM6DSOXDevice
from roboray.sim.twin.board.lis3mdl_device import LIS3MDLDevice
gc.collect()
emulation = gc.mem_alloc() - base
i0 = emuboard.insns()
gc.collect()
emulation_gc = emuboard.insns() - i0
%(setup)s
%(build)s
v.sched.run(300)
from roboray.firmware import collector
out = {"emulation_bytes": emulation, "base_bytes": base, "emulation_gc_insns": emulation_gc}
def collections(n):
    samples = []
    for k in range(n):
        v.sched.run(20)
        i0 = emuboard.insns()
        collector.collect()
        samples.append(emuboard.insns() - i0)
    return samples
out["gc_insns_unordered"] = collections(3)
app.vehicle = v
i0 = emuboard.insns()
out["chain"] = collector.prepare()
out["prepare_insns"] = emuboard.insns() - i0
gc.collect()
out["gc_insns"] = collections(5)
out["live_bytes"] = gc.mem_alloc()
out["free_bytes"] = gc.mem_free()
out["float_single"] = (1.0 + 1e-8 == 1.0)
out["maxsize"] = sys.maxsize
print("RESULT " + json.dumps(out))
"""


def _probe(romfs: bool, build: str = "roboray") -> dict:
    """The firmware built on the emulated board without the world: its live
    heap, the emulated peripherals' share, one collection (instructions)."""
    from roboray.sim import twin
    from roboray.sim.twin import bench
    from roboray.tools.micropython import rp2350_emu

    code = _GC_PROBE % {"prelude": twin.PRELUDE, "setup": bench.SETUP.replace("import gc, machine, time", "import machine, time"),
                        "build": bench.BUILD % "bench_params.bin"}
    with tempfile.TemporaryDirectory(prefix="roboray-board-") as d:
        heap = rp2350_emu.PICO2_HEAP + rp2350_emu.TWIN_HEAP
        if romfs:
            src = Path(d) / "romsrc"
            rp2350_emu.install_lib(src / "lib")
            status, out = rp2350_emu.run(code, cwd=d, heap_bytes=heap, romfs=rp2350_emu.make_romfs(src), timeout=600,
                                         build=build)
        else:
            lib = rp2350_emu.install_lib(Path(d) / "lib")
            status, out = rp2350_emu.run(code, cwd=d, heap_bytes=heap, path=(str(lib),), timeout=600, build=build)
    for line in out.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    raise CliError("the emulated board did not finish the heap probe (exit %d): %s" % (status, out.strip()[-500:]))


#: Counts one benchmark's work: compiled first, then run between two readings.
_COUNT = """
import emuboard, gc
src = open(%(path)r).read()
code = compile(src, "bench", "exec")
del src
gc.collect()
i0 = emuboard.insns()
exec(code, {"__name__": "bench"})
print("COUNT %%d" %% (emuboard.insns() - i0))
"""


def calibrate() -> dict:
    """Count the published benchmarks' work on the emulated board (each run
    at its published size less the same script with no work) and calibrate
    (``tools/rp2350_emu/calibration.py``)."""
    from roboray.tools.micropython import rp2350_emu
    from roboray.tools.rp2350_emu import calibration

    counts = {}
    with tempfile.TemporaryDirectory(prefix="roboray-cal-") as d:
        for name, bench in calibration.BENCHMARKS.items():
            if not bench.verified:
                continue
            got = []
            for n in (bench.iterations, 0):
                path = Path(d) / ("%s_%d.py" % (name, n))
                path.write_text(calibration.script(name, n))
                # stock: the build the published timings were measured on
                status, out = rp2350_emu.run(_COUNT % {"path": str(path)}, cwd=d, timeout=600, build="stock")
                line = next((x for x in out.splitlines() if x.startswith("COUNT ")), None)
                if status != 0 or line is None:
                    raise CliError("benchmark %s failed on the emulated board (exit %d): %s"
                                   % (name, status, out.strip()[-500:]))
                got.append(int(line.split()[1]))
            counts[name] = got[0] - got[1]
    cal = calibration.calibrate(counts)
    return {"ps_per_insn": round(cal["ps_per_insn"], 1), "cpi": round(cal["cpi"], 3),
            "relative_uncertainty": round(cal["half_range_rel"], 3),
            "std_rel": round(cal["std_rel"], 3) if cal["std_rel"] is not None else None,
            "min_ps_per_insn": round(cal["min_ps_per_insn"], 1), "max_ps_per_insn": round(cal["max_ps_per_insn"], 1),
            "method": cal["method"],
            "per_benchmark": {n: {"instructions": b["instructions"], "ps_per_insn": round(b["ps_per_insn"], 1),
                                  "figures": [{"label": f["label"], "published_s": f["published_s"],
                                               "ps_per_insn": round(f["ps_per_insn"], 1), "url": f["url"],
                                               "representative": f["representative"]} for f in b["figures"]]}
                              for n, b in cal["benchmarks"].items()}}


def _twin_run(scenario: str, cpu_mhz: float, romfs: bool, seed: int = 0,
              build: str = "roboray") -> tuple[dict, "object"]:
    from roboray.sim.twin.runner import Options, Twin

    twin = Twin(Options(scenario=scenario, seed=seed, interpreter="rp2350-emu", cpu_mhz=cpu_mhz, romfs=romfs,
                        emu_build=build, count_heap=True))
    report = twin.run()
    return report, twin


def slots_without_flash(twin) -> dict:
    """Slot p99 and max with the collections, without the slots a flash
    write stalled (a parameter or dive-state save): what the collector
    leaves of the loop's time."""
    kind, _, us = twin.times.records()
    keep = []
    flash = False
    for k, u in zip(kind.tolist(), us.tolist()):
        if k == 17:      # a slot's records end with its SLOT record
            if not flash:
                keep.append(u)
            flash = False
        elif k == 18:
            flash = True
    if not keep:
        return {}
    a = np.asarray(keep)
    return {"slot_p99_ms_no_flash": round(float(np.percentile(a, 99)) / 1000.0, 3),
            "slot_max_ms_no_flash": round(float(a.max()) / 1000.0, 3)}


def flight_heap(twin) -> dict:
    """Collections and bytes allocated a slot while armed, from the board's
    records (``ALLOC``, ``AUTO_GC``, the "gc" task: ``board/boardtime.py``)."""
    from roboray.sim.twin.board import boardtime

    names = twin.board_report.get("task_names") or []
    kind, mode, us = twin.times.records()
    armed = mode != 0      # shared/modes.py: DISARMED
    planned = (kind == names.index("gc")) if "gc" in names else np.zeros(len(kind), dtype=bool)
    collections = int((armed & (planned | (kind == boardtime.AUTO_GC) | (kind == boardtime.GC))).sum())
    alloc = us[armed & (kind == boardtime.ALLOC)]
    return {"flight_collections": collections,
            "flight_alloc_bytes_per_slot": round(float(alloc.mean()), 1) if len(alloc) else None,
            "flight_alloc_bytes_max": int(alloc.max()) if len(alloc) else None,
            "flight_slots": int(len(alloc))}


def model_from(runs: list) -> dict:
    """Per task and mode, the mean cost a call (us at 150 MHz) from twins run
    on the emulated board, calls that wrote to flash left out; modes a run
    did not visit take the nearest one's (ATTITUDE: VELOCITY's cascade;
    FAILSAFE: PASSIVE's fixed wings)."""
    from roboray.shared.modes import NAMES

    sums: dict = {}
    for report, twin in runs:
        names = twin.board_report.get("task_names") or []
        kind, mode, us = twin.times.records()
        # A flash stall is charged apart (the model's twin charges it from
        # the file operations), and the call it fell in (a parameter or
        # dive-state save, the next task record after it) is left out: a
        # save's own work averaged into a mode's few calls made every call
        # of that mode cost it (PASSIVE's parameter task 45 ms a call, and a
        # model twin resting on the bottom overran every second).
        flashed = np.zeros(len(kind), dtype=bool)
        stall = False
        for j in range(len(kind)):
            if kind[j] == 18:
                stall = True
            elif stall and kind[j] < 16:
                flashed[j] = True
                stall = False
        for i, name in enumerate(names):
            for m in range(len(NAMES)):
                sel = (kind == i) & (mode == m) & ~flashed
                if sel.any():
                    s = sums.setdefault(name, {}).setdefault(m, [0.0, 0])
                    s[0] += float(us[sel].sum())
                    s[1] += int(sel.sum())
        gsel = kind == 16
        s = sums.setdefault("__gc__", {}).setdefault(0, [0.0, 0])
        s[0] += float(us[gsel].sum())
        s[1] += int(gsel.sum())
    fallback = {"DISARMED": ("PASSIVE",), "PASSIVE": ("DISARMED",), "ATTITUDE": ("VELOCITY", "TARGET"),
                "VELOCITY": ("TARGET",), "TARGET": ("VELOCITY",), "FAILSAFE": ("PASSIVE", "DISARMED")}
    tasks = {}
    for name, by_mode in sums.items():
        if name == "__gc__":
            continue
        costs = []
        for m, mname in enumerate(NAMES):
            cands = [m] + [NAMES.index(f) for f in fallback[mname]]
            got = next((by_mode[c] for c in cands if c in by_mode and by_mode[c][1]), None)
            if got is None:
                got = [sum(v[0] for v in by_mode.values()), sum(v[1] for v in by_mode.values())]
            costs.append(round(got[0] / max(got[1], 1), 1))
        tasks[name] = costs
    g = sums["__gc__"][0]
    return {"tasks": tasks, "gc_us": round(g[0] / max(g[1], 1), 1), "modes": list(NAMES)}


def _model_check(emu_tasks: dict) -> dict:
    """The default twin (WebAssembly port) charging the model on the
    standard scenario: per task, its mean a call against the emulated
    board's (ratio: model / counted)."""
    from roboray.sim.twin.runner import Options, run

    report = run(Options(scenario="target-landing", board_time="model"))
    bt = report["board_time"]
    out = {"landing_error_m": report.get("landing_error_m"), "slot_p99_ms": report.get("slot_p99_ms"), "tasks": {}}
    for name, s in bt["tasks"].items():
        e = emu_tasks.get(name, {})
        if s.get("calls") and e.get("calls") and e.get("mean_us"):
            out["tasks"][name] = {"model_mean_us": s["mean_us"], "counted_mean_us": e["mean_us"],
                                  "ratio": round(s["mean_us"] / e["mean_us"], 3)}
    return out


def _metres(value) -> str:
    """A landing error as the sil report gives it (mm), or why there is none:
    the run's figure is a raw double (0.012345678901 m)."""
    return "%.3f" % value if value is not None else "none (no landing)"


def do_bench_board(args: argparse.Namespace) -> None:
    from roboray.sim.twin import timing
    from roboray.tools.micropython import rp2350_emu
    try:
        rp2350_emu.require()
    except RuntimeError as exc:
        raise CliError(str(exc))
    t0 = time.perf_counter()
    sys.stderr.write("bench board: calibrating on the emulated RP2350...\n")
    cal = calibrate()
    if args.write_model:
        # the calibration first: the twin runs below charge at its figure
        timing.write_model({"calibration": cal}, partial=True)
    sys.stderr.write("bench board: %.3f ns an instruction (+-%.0f%%); target-landing on the emulated board...\n"
                     % (cal["ps_per_insn"] / 1000.0, 100 * cal["relative_uncertainty"]))
    report, twin = _twin_run("target-landing", args.cpu_mhz, args.romfs, build=args.build)
    runs = [(report, twin)]
    bt = report["board_time"]
    bt_extra = slots_without_flash(twin)
    sys.stderr.write("bench board: the firmware's heap and one collection...\n")
    probe = _probe(args.romfs, args.build)
    ps = cal["ps_per_insn"] * timing.REF_MHZ / args.cpu_mhz
    gc_us = [n * ps / 1e6 for n in probe["gc_insns"]]
    gc_us_unordered = [n * ps / 1e6 for n in probe["gc_insns_unordered"]]
    build = rp2350_emu.interpreter_build(args.build)
    result = {
        "board": "emulated RP2350 (%s %s, QEMU mps3-an547, Cortex-M33 code, -icount)%s" % (
            args.build, build["version"], ", board code in ROMFS" if args.romfs else ""),
        "build": args.build,
        "obj_repr": build["obj_repr"],
        "cpu_mhz": args.cpu_mhz,
        "scenario": "target-landing",
        "landing_error_m": report.get("landing_error_m"),
        "tasks": bt["tasks"],
        "gc": bt["gc"],
        "slot_p50_ms": bt.get("slot_p50_ms"),
        "slot_p99_ms": bt.get("slot_p99_ms"),
        "slot_max_ms": bt.get("slot_max_ms"),
        "slot_p99_ms_no_stall": bt.get("slot_p99_ms_no_stall"),
        "slot_max_ms_no_stall": bt.get("slot_max_ms_no_stall"),
        "planned_stalls": report["planned_stalls"],
        "load_pct": bt.get("load_pct"),
        "overruns": report["overruns"],
        "skipped_slots": report["skipped_slots"],
        "resets": report["resets"],
        "flash_stalls": bt.get("flash_stalls"),
        "flash_stall_ms": bt.get("flash_stall_ms"),
        "slot_p99_ms_no_flash": bt_extra.get("slot_p99_ms_no_flash"),
        "slot_max_ms_no_flash": bt_extra.get("slot_max_ms_no_flash"),
        **flight_heap(twin),
        "gc_ms": round(float(np.median(gc_us)) / 1000.0, 3),
        "gc_ms_unordered": round(float(np.median(gc_us_unordered)) / 1000.0, 3),
        "gc_insns": int(np.median(probe["gc_insns"])),
        "gc_insns_unordered": int(np.median(probe["gc_insns_unordered"])),
        "gc_order_objects": probe["chain"],
        "gc_order_prepare_ms": round(probe["prepare_insns"] * ps / 1e9, 1),
        "heap_live_bytes": probe["live_bytes"] - probe["emulation_bytes"],
        "heap_live_emulation_bytes": probe["emulation_bytes"],
        "heap_size_bytes": rp2350_emu.PICO2_HEAP,
        "heap_size_source": rp2350_emu.PICO2_HEAP_SOURCE,
        "float_impl": "float" if probe["float_single"] else "double",
        "word_bits": 32 if probe["maxsize"] == 2 ** 31 - 1 else 64,
        "calibration": cal,
        "seconds": None,
    }
    if args.write_model:
        sys.stderr.write("bench board: velocity on the emulated board (the model's VELOCITY costs)...\n")
        runs.append(_twin_run("velocity", timing.REF_MHZ, args.romfs, build=args.build))
        model = model_from(runs)
        # the collection at the firmware's own heap, not the twin's: the
        # twin's objects share the emulated heap and lengthen it
        model["tasks"]["gc"] = [round(result["gc_ms"] * 1000.0, 1)] * len(model["tasks"]["gc"])
        model["calibration"] = cal
        model["source"] = ("roboray-sim bench board --write-model: target-landing and velocity on the emulated "
                           "RP2350 at 150 MHz")
        path = timing.write_model(model)
        result["model"] = str(path)
        sys.stderr.write("bench board: target-landing on the WebAssembly port with the model...\n")
        result["model_check"] = _model_check(bt["tasks"])
    result["seconds"] = round(time.perf_counter() - t0, 1)

    def text(r: dict) -> str:
        lines = ["%s at %g MHz, %s (landing error %s m)" % (r["board"], r["cpu_mhz"], r["scenario"],
                                                             _metres(r["landing_error_m"])),
                 "   task        calls   mean us    p99 us    max us"]
        for name, s in r["tasks"].items():
            if s.get("calls"):
                lines.append("   %-10s %6d %9.1f %9.1f %9d" % (name, s["calls"], s["mean_us"], s["p99_us"],
                                                                  s["max_us"]))
        g = r["gc"]
        if g.get("calls") and "gc" not in r["tasks"]:
            lines.append("   %-10s %6d %9.1f %9.1f %9d" % ("gc", g["calls"], g["mean_us"], g["p99_us"], g["max_us"]))
        lines.append("slot p50 %s ms, p99 %s ms, max %s ms (without the collector's and flash stalls: p99 %s, max %s "
                     "ms); load %s%%; %s overruns, %s planned stalls, %s skipped slots, %s resets" % (
                         r["slot_p50_ms"], r["slot_p99_ms"], r["slot_max_ms"], r["slot_p99_ms_no_stall"],
                         r["slot_max_ms_no_stall"], r["load_pct"], r["overruns"], r["planned_stalls"],
                         r["skipped_slots"], r["resets"]))
        lines.append("with the collections, without flash stalls: slot p99 %s ms, max %s ms" % (
            r["slot_p99_ms_no_flash"], r["slot_max_ms_no_flash"]))
        lines.append("armed (%s slots): %s collections, %s bytes allocated a slot (max %s); floats %s (REPR_%s)" % (
            r["flight_slots"], r["flight_collections"], r["flight_alloc_bytes_per_slot"], r["flight_alloc_bytes_max"],
            "in the object word" if r["obj_repr"] == "C" else "boxed on the heap", r["obj_repr"]))
        lines.append("one gc.collect() at the firmware's live heap: %.3f ms in the collector's order (%d objects, "
                     "ordered in %.0f ms at start-up), %.3f ms without it (live %d B + %d B emulated peripherals, "
                     "heap %d B)" % (r["gc_ms"], r["gc_order_objects"], r["gc_order_prepare_ms"], r["gc_ms_unordered"],
                                     r["heap_live_bytes"], r["heap_live_emulation_bytes"], r["heap_size_bytes"]))
        c = r["calibration"]
        lines.append("calibration: %.3f ns an instruction at 150 MHz (CPI %.2f), +-%.0f%% (%s)" % (
            c["ps_per_insn"] / 1000.0, c["cpi"], 100 * c["relative_uncertainty"],
            ", ".join(c["per_benchmark"])))
        if r.get("model"):
            lines.append("wrote %s" % r["model"])
            m = r["model_check"]
            lines.append("the model on the WebAssembly port, target-landing (landing error %s m, slot p99 %s ms), "
                         "mean a call against the counted one:" % (_metres(m["landing_error_m"]), m["slot_p99_ms"]))
            lines.append("   " + ", ".join("%s %.2f" % (n, t["ratio"]) for n, t in m["tasks"].items()))
        return "\n".join(lines)

    emit(args, result, text)


def register(sub, bench) -> None:
    from roboray.sim.commands.sil import cpu_mhz

    p = command(bench, "board", do_bench_board,
                "the firmware's time on the emulated RP2350: tasks, slots, collector, heap, calibration")
    from roboray.tools.micropython.rp2350_emu import BUILDS

    p.add_argument("--cpu-mhz", type=cpu_mhz, default=150.0, help="the board's clock (default 150)")
    p.add_argument("--build", choices=BUILDS, default="roboray",
                   help="the emulated board's MicroPython: roboray (the default: RoboRay's build, floats in the "
                        "object word) or stock (floats boxed on the heap, as rp2 ships); the instructions are "
                        "calibrated on stock either way")
    p.add_argument("--romfs", action=argparse.BooleanOptionalAction, default=True,
                   help="the board code in the Pico 2's ROMFS partition (run in place from flash, as "
                        "roboray-flash deploy puts it; the default), or with --no-romfs in /lib")
    p.add_argument("--write-model", action="store_true",
                   help="also write the per-task costs the default twin charges (sim/twin/board_time_model.json)")
    add_json(p)
