"""``roboray-ground``: the ground station.

MAVProxy's conventions where they exist: ``--master`` takes pymavlink's
connection strings, ``--baudrate`` defaults to 57600 (SiK radios),
``--source-system`` to 255, ``--key``/``--key-file`` set up MAVLink 2
signing with MAVProxy's key derivation. The link options go before the
command (MAVProxy's order) or after it; ``--master`` defaults to the
``ROBORAY_MASTER`` environment variable, and ``auto`` finds a SiK radio by
its USB ids (``ground/radios.py``). Link handling lives in
``ground/link.py``; this module only parses, dispatches and prints.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from typing import Any, Optional, Sequence

from roboray.tools.cli import (CliError, UsageError, add_json, check_target, command, emit, glide_reach, make_parser,
                               number, output_file, positive, run)

#: The environment variable that gives ``--master`` when it is not typed.
MASTER_ENV = "ROBORAY_MASTER"


def do_ports(args: argparse.Namespace) -> None:
    """Serial ports pyserial can see, with their USB ids (radios show up here)."""
    from serial.tools import list_ports

    ports = [
        {
            "device": p.device,
            "description": p.description,
            "vid": p.vid,
            "pid": p.pid,
            "serial_number": p.serial_number,
        }
        for p in sorted(list_ports.comports(), key=lambda p: p.device)
    ]

    def text(rows: list) -> str:
        if not rows:
            return "no serial ports found"
        return "\n".join(
            "%-20s %s%s" % (r["device"], r["description"],
                            "" if r["vid"] is None else "  [%04x:%04x]" % (r["vid"], r["pid"]))
            for r in rows
        )

    emit(args, ports, text)


# ------------------------------------------------------------------ link
def _key(args: argparse.Namespace) -> Optional[bytes]:
    from roboray.ground.link import key_from_passphrase, read_key_file

    if getattr(args, "key", None) and getattr(args, "key_file", None):
        raise UsageError("give --key or --key-file, not both")
    if getattr(args, "key_file", None):
        return key_from_passphrase(read_key_file(args.key_file))
    if getattr(args, "key", None):
        return key_from_passphrase(args.key)
    return None


def _master(args: argparse.Namespace) -> str:
    """The link to open: ``--master``, else ``$ROBORAY_MASTER``; ``auto``
    is the one SiK radio plugged in."""
    from roboray.ground import radios
    from roboray.ground.link import parse_master

    master = getattr(args, "master", None) or os.environ.get(MASTER_ENV, "").strip()
    if not master:
        raise UsageError("no link: give --master (before or after the command: a serial port, udp:PORT, "
                         "tcp:HOST:PORT, ... or auto) or set %s" % MASTER_ENV)
    return parse_master(radios.pick(master))


def _connect(args: argparse.Namespace):
    from roboray.ground.link import Link

    link = Link(_master(args), args.baudrate, args.source_system, _key(args), connect_timeout=args.timeout)
    try:
        link.wait_heartbeat(args.timeout)
    except BaseException:
        link.close()
        raise
    return link


def _baudrate(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("%r is not a baud rate (a whole number, e.g. 57600)" % text)
    if value <= 0:
        raise argparse.ArgumentTypeError("%r is not a baud rate (a whole number, e.g. 57600)" % text)
    return value


def _system_id(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 1 <= value <= 255:
        raise argparse.ArgumentTypeError("%r is not a MAVLink system id (1 to 255)" % text)
    return value


def _link_options(p: argparse.ArgumentParser, top: bool = False) -> None:
    """MAVProxy's link options. On the top-level parser with their defaults;
    on a command's without (SUPPRESS), so that one given before the command
    is not overwritten by the command's default."""
    def default(value: Any) -> Any:
        return value if top else argparse.SUPPRESS

    g = p.add_argument_group("link (MAVProxy's options, before or after the command)")
    g.add_argument("--master", default=default(None), metavar="DEVICE",
                   help="serial port (PATH or PATH,BAUD); udp:PORT (listen on 0.0.0.0:PORT, as udpin:PORT), "
                        "udpin:HOST:PORT, udpout:HOST:PORT; tcp:HOST:PORT (tcp:PORT: this machine's), "
                        "tcpin:PORT; or auto: the one SiK radio plugged in (USB ids 0403:6015, 10c4:ea60) "
                        "(default: $%s). Exit 3 when the link closes under the command (the port went away)"
                        % MASTER_ENV)
    g.add_argument("--baudrate", type=_baudrate, default=default(57600), help="serial baud rate (default 57600)")
    g.add_argument("--source-system", type=_system_id, default=default(255),
                   help="our MAVLink system id, 1 to 255 (default 255)")
    g.add_argument("--key", metavar="PASSPHRASE", default=default(None),
                   help="sign with the key MAVProxy derives from PASSPHRASE")
    g.add_argument("--key-file", metavar="FILE", default=default(None),
                   help="read the signing passphrase from FILE's first line")
    g.add_argument("--timeout", type=positive, default=default(5.0), metavar="S",
                   help="seconds to wait for the vehicle's heartbeat, and for a TCP connection (default 5)")


# ---------------------------------------------------------------- status
def do_status(args: argparse.Namespace) -> None:
    """One look at the vehicle: heartbeat, then a second of telemetry."""
    from roboray.ground.watch import State, render

    link = _connect(args)
    state = State()
    state.update(link.vehicle_heartbeat)
    link.on_message = state.update
    try:
        end = time.monotonic() + args.listen
        while time.monotonic() < end:
            link.recv(0.1)
    finally:
        link.close()
    deg = 180.0 / math.pi
    result = {
        "source": link.describe(), "system": link.target_system, "component": link.target_component,
        "mode": state.mode_name(), "armed": state.armed,
        "roll_deg": state.att[0] * deg, "pitch_deg": state.att[1] * deg, "yaw_deg": state.att[2] * deg,
        "depth_m": state.depth, "position_ned_m": list(state.pos), "velocity_ned_mps": list(state.vel),
        "wings_deg": state.wings, "battery_v": state.battery_v, "battery_pct": state.battery_pct,
        "failsafe_flags": state.failsafe_flags, "load_pct": state.load_pct, "worst_slot_ms": state.worst_slot_ms,
        "frames": state.received, "lost": state.lost,
    }
    emit(args, _finite(result), lambda r: "\n".join(render(state, link.describe())))


def _finite(o: Any) -> Any:
    """NaN (not received) as null, so --json stays strict JSON."""
    if isinstance(o, float) and not math.isfinite(o):
        return None
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, list):
        return [_finite(v) for v in o]
    return o


# -------------------------------------------------------------- commands
MAV_CMD_COMPONENT_ARM_DISARM = 400
MAV_CMD_DO_SET_MODE = 176
MAV_CMD_DO_REPOSITION = 192
MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN = 246
FORCE_ARM = 21196


def _arm_disarm(args: argparse.Namespace, arm: int) -> None:
    """Arming is a flag: the vehicle keeps its mode, which the answer names."""
    from roboray.shared import modes

    name = "arm" if arm else "disarm"
    link = _connect(args)
    try:
        link.command(MAV_CMD_COMPONENT_ARM_DISARM, (arm, FORCE_ARM if args.force else 0), timeout=args.ack_timeout,
                     name=name)
        mode = modes.custom_name(link.vehicle_heartbeat.custom_mode)
    finally:
        link.close()
    emit(args, {"command": name, "result": "accepted", "mode": mode},
         lambda r: "%s in %s" % ("armed" if arm else "disarmed", mode))


def do_arm(args: argparse.Namespace) -> None:
    _arm_disarm(args, 1)


def do_disarm(args: argparse.Namespace) -> None:
    _arm_disarm(args, 0)


def do_reboot(args: argparse.Namespace) -> None:
    """PREFLIGHT_REBOOT_SHUTDOWN with param1 = 1, as MAVProxy's ``reboot``:
    what only start-up reads (servo end points, the battery multiplier, the
    compass and the board's orientation) takes effect. The vehicle saves its
    parameters first and refuses while armed."""
    from roboray.ground.link import LinkError

    link = _connect(args)
    try:
        link.command(MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (1,), timeout=args.ack_timeout, name="reboot")
        back = None
        if args.wait:
            # the vehicle is back when it says which firmware it runs (its
            # first STATUSTEXT after a start) or its boot clock (time_boot_ms
            # of ATTITUDE, SYSTEM_TIME) starts again from near zero, and its
            # heartbeat is heard after that; a silence alone says little (a
            # restart can be shorter than a heartbeat's period)
            start = time.monotonic()
            end = start + args.wait
            last_boot_ms = -1
            restarted = False
            while time.monotonic() < end:
                try:
                    m = link.recv(0.1)
                except LinkError:
                    m = None   # a USB radio that went away with the board's power
                if m is None:
                    continue
                if m.get_type() == "STATUSTEXT" and m.text.startswith("RoboRay firmware"):
                    restarted = True
                boot_ms = getattr(m, "time_boot_ms", None)
                if boot_ms is not None:
                    if 0 <= boot_ms < last_boot_ms - 500:
                        restarted = True
                    last_boot_ms = boot_ms
                if restarted and m.get_type() == "HEARTBEAT" and m.type != 6:
                    back = time.monotonic() - start
                    break
            if back is None:
                raise LinkError("reboot accepted, but the vehicle was not heard back within %g s (--wait): "
                                "check its power and console" % args.wait)
    finally:
        link.close()
    emit(args, {"command": "reboot", "result": "accepted", "back_after_s": back},
         lambda r: "rebooting" + ("" if back is None else ": back after %.1f s" % back))


def do_mode(args: argparse.Namespace) -> None:
    """DO_SET_MODE with the mode's custom number; RoboRay's names, or the
    ArduSub names MAVProxy and QGroundControl show (``shared/modes.py``)."""
    from roboray.shared import modes

    m = modes.mode_number(args.name)
    if m < 0:
        if args.name.upper() == "DISARMED":
            raise UsageError("DISARMED is no mode: the vehicle keeps its mode disarmed; use disarm")
        raise UsageError("unknown mode %r: choose from %s (or the names ground stations show: %s)" % (
            args.name, ", ".join(modes.NAMES[i] for i in modes.MODES),
            ", ".join(modes.ARDUSUB_NAMES[i] for i in modes.MODES)))
    name = modes.NAMES[m]
    link = _connect(args)
    try:
        link.command(MAV_CMD_DO_SET_MODE, (1, modes.CUSTOM[m]), timeout=args.ack_timeout, name="mode %s" % name)
    finally:
        link.close()
    emit(args, {"command": "mode %s" % name, "result": "accepted", "mode": name, "custom_mode": modes.CUSTOM[m],
                "ground_station_name": modes.ARDUSUB_NAMES[m]},
         lambda r: "mode %s (%s in MAVProxy and QGroundControl)" % (name, modes.ARDUSUB_NAMES[m]))


#: The deepest bottom a target may be given (CTL_DEPTH_M's maximum, the
#: MS5837-30BA's range): the reach checked before the link opens.
DEEPEST_M = 300.0


def _plausible_target(north: float, east: float, down: Optional[float]) -> None:
    """A target within a glide's reach of the bottom at ``down`` (or of the
    deepest a target may be), refused before the link opens."""
    if down is not None:
        check_target(north, east, down, 0.0, " (--down)")
    else:
        check_target(north, east, DEEPEST_M, 0.0, " (the deepest a target may be: give --down)")


def do_target(args: argparse.Namespace) -> None:
    """Send the target after checking it is within reach: from the surface
    to ``--down`` when given; else to the deepest bottom before the link
    opens, then to the vehicle's own ``CTL_DEPTH_M`` (the bottom it assumes)."""
    from roboray.ground.link import LinkError

    north, east = args.north, args.east
    _plausible_target(north, east, args.down)
    link = _connect(args)
    try:
        bottom, whose = args.down, "--down"
        if bottom is None:
            try:
                bottom, _ = link.param_get("CTL_DEPTH_M", timeout=min(args.ack_timeout, 3.0))
                bottom, whose = float(bottom), "CTL_DEPTH_M"
            except LinkError:
                whose = "unknown: the vehicle did not say its CTL_DEPTH_M"
            else:
                check_target(north, east, bottom, 0.0, " (the vehicle's CTL_DEPTH_M: give --down)")
        link.command(MAV_CMD_DO_REPOSITION, (-1, 0, 0, math.nan, north, east, math.nan if args.down is None
                                             else args.down), timeout=args.ack_timeout, name="target")
    finally:
        link.close()
    result = {"command": "target", "result": "accepted", "north_m": north, "east_m": east,
              "distance_m": math.hypot(north, east), "bottom_m": bottom, "bottom_from": whose,
              "reach_m": None if bottom is None else glide_reach(bottom)}

    def text(r: dict) -> str:
        line = "target %.2f m north, %.2f m east (%.2f m away)" % (north, east, r["distance_m"])
        if bottom is None:
            return line + ", on the vehicle's own bottom depth (%s)" % whose
        return line + ", bottom at %.1f m (%s): reach %.2f m" % (bottom, whose, r["reach_m"])

    emit(args, result, text)


# --------------------------------------------------------------- mission
#: Each wp action's arguments: (fewest, most, usage).
_WP_USAGE = {"list": (0, 0, "wp list"), "set": (2, 2, "wp set NORTH EAST [--down D]"), "clear": (0, 0, "wp clear")}


def do_wp(args: argparse.Namespace) -> None:
    """The landing target as a mission, as MAVProxy's ``wp``: ``list`` downloads
    it, ``set`` uploads home and the target (its reach checked as ``target``
    checks it before the link opens, then by the vehicle against its own
    bottom depth), ``clear`` removes it."""
    from roboray.ground import mission

    fewest, most, usage = _WP_USAGE[args.action]
    if not fewest <= len(args.rest) <= most:
        raise UsageError("usage: roboray-ground %s" % usage)
    if args.down is not None and args.action != "set":
        raise UsageError("--down goes with wp set")
    north = east = 0.0
    if args.action == "set":
        try:
            north, east = (number(a) for a in args.rest)
        except argparse.ArgumentTypeError as exc:
            raise UsageError("wp set: %s" % exc)
        _plausible_target(north, east, args.down)
    link = _connect(args)
    try:
        if args.action == "list":
            items = mission.download(link, args.ack_timeout)
        elif args.action == "set":
            mission.upload(link, mission.target_item(north, east, args.down), args.ack_timeout)
        else:
            mission.clear(link, args.ack_timeout)
    except mission.MissionRefused as exc:
        if exc.result in mission.VALUE_RESULTS:
            raise UsageError(str(exc))   # the vehicle found the value wrong: a mistake in the arguments
        raise
    finally:
        link.close()
    if args.action == "set":
        bottom_from = "--down" if args.down is not None else "CTL_DEPTH_M"
        result = {"command": "wp set", "result": "accepted", "north_m": north, "east_m": east,
                  "distance_m": math.hypot(north, east), "bottom_m": args.down, "bottom_from": bottom_from}
        emit(args, result, lambda r: "mission set: target %.2f m north, %.2f m east (%.2f m away), %s"
             % (north, east, r["distance_m"], "bottom at %.1f m (--down)" % args.down if args.down is not None
                else "on the vehicle's own bottom depth (CTL_DEPTH_M)"))
    elif args.action == "clear":
        emit(args, {"command": "wp clear", "result": "accepted"}, lambda r: "mission cleared: no target")
    else:
        _wp_list(args, items)


def _wp_list(args: argparse.Namespace, items: list) -> None:
    from roboray.ground import mission

    target = mission.target_of(items)
    tgt = None
    if target is not None:
        tgt = {"north_m": target.north_m, "east_m": target.east_m, "down_m": target.down_m,
               "distance_m": math.hypot(target.north_m, target.east_m),
               "frame": mission.FRAME_NAMES.get(target.frame, str(target.frame)),
               "latitude_deg": target.latitude, "longitude_deg": target.longitude}
    result = {"count": len(items), "items": [mission.describe_item(m) for m in items], "target": tgt}

    def text(r: dict) -> str:
        lines = []
        for it in r["items"]:
            what = "the release point"
            if it["command"] == "NAV_LAND" and tgt is not None:
                what = "%.2f m north, %.2f m east (%.2f m away), %s" % (
                    tgt["north_m"], tgt["east_m"], tgt["distance_m"],
                    "bottom at %.1f m" % tgt["down_m"] if tgt["down_m"] is not None
                    else "on the vehicle's own bottom depth (CTL_DEPTH_M)")
                if tgt["latitude_deg"] is not None:
                    what += "; %.7f, %.7f deg from home at 0, 0" % (tgt["latitude_deg"], tgt["longitude_deg"])
            lines.append("%d  %-6s  %-12s  %-9s  %s" % (it["seq"], "home" if it["seq"] == 0 else "target",
                                                         it["command"], it["frame"], what))
        if tgt is None:
            lines.append("no target: the mission is home alone")
        return "\n".join(lines)

    emit(args, result, text)


# ------------------------------------------------------------ parameters
def _fetch_all(args: argparse.Namespace) -> dict:
    link = _connect(args)
    try:
        return link.param_list(args.param_timeout)
    finally:
        link.close()


#: Each action's arguments: (fewest, most, usage).
_PARAM_USAGE = {
    "list": (0, 0, "param list"), "get": (1, 1, "param get NAME"), "set": (2, 2, "param set NAME VALUE"),
    "show": (0, 1, "param show [PATTERN] [-v] [--cached]"), "fetch": (0, 1, "param fetch [NAME]"),
    "save": (1, 1, "param save FILE"), "load": (1, 1, "param load FILE"), "diff": (1, 1, "param diff FILE"),
    "pdef": (1, 1, "param pdef FILE.xml"),
}


def _param_cache_path() -> str:
    """Where ``param fetch`` keeps the list it fetched (``show --cached`` reads it)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "roboray", "params.json")


def _cache_params(args: argparse.Namespace, values: dict) -> None:
    path = _param_cache_path()
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        tmp = path + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump({"master": getattr(args, "master", None), "time": time.time(),
                       "values": {k: list(v) for k, v in values.items()}}, f)
        os.replace(tmp, path)
    except OSError:
        pass    # a cache that cannot be written is only a cache


def _cached_params() -> dict:
    path = _param_cache_path()
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
        return {k: (float(v[0]), int(v[1])) for k, v in data["values"].items()}
    except FileNotFoundError:
        raise CliError("no parameter list cached yet: run param fetch first (or leave out --cached)")
    except (OSError, ValueError, KeyError, TypeError, IndexError) as exc:
        raise CliError("%s: not a parameter cache (%s): run param fetch again" % (path, exc))


def _param_show(args: argparse.Namespace, values: dict, pattern: str) -> None:
    """MAVProxy's ``param show``: the parameters whose names match PATTERN
    (fnmatch wildcards, any case); ``-v`` adds units, range, description."""
    import fnmatch

    from roboray.firmware.app import PARAMS
    from roboray.ground.link import fmt_value
    from roboray.shared.param_meta import META

    decls = {d[0]: d for d in PARAMS}
    want = pattern.upper()
    names = [k for k in sorted(values) if fnmatch.fnmatchcase(k, want)]
    if not names:
        raise CliError("no parameter matches %s (%d on the vehicle)" % (pattern, len(values)))
    rows = []
    for k in names:
        value, ptype = values[k]
        row: dict = {"name": k, "value": value, "text": fmt_value(value, ptype)}
        if args.describe:
            display, unit, description, codes, _ = META.get(k, ("", "", "", (), ""))
            d = decls.get(k)
            row.update(units=unit, description=description, values={str(c): label for c, label in codes},
                       range=None if d is None else [d[3], d[4]],
                       read_only=bool(d is not None and len(d) > 5 and d[5] & 1))
            if d is not None:
                row["range_text"] = "%s .. %s" % (fmt_value(d[3], ptype), fmt_value(d[4], ptype))
        rows.append(row)

    def text(_: object) -> str:
        lines = []
        for x in rows:
            lines.append("%-16s %s%s" % (x["name"], x["text"], (" " + x["units"]) if x.get("units") else ""))
            if args.describe:
                extra = []
                if x.get("range_text"):
                    extra.append("range " + x["range_text"])
                if x["values"]:
                    extra.append(", ".join("%s: %s" % kv for kv in x["values"].items()))
                if x["read_only"]:
                    extra.append("read-only")
                if x["description"]:
                    lines.append("    " + x["description"])
                if extra:
                    lines.append("    " + "; ".join(extra))
        return "\n".join(lines)

    emit(args, rows if args.describe else {x["name"]: x["value"] for x in rows}, text)


def _param_pdef(args: argparse.Namespace, path: str) -> None:
    from roboray.firmware.app import PARAMS
    from roboray.ground import paramfile
    from roboray.shared.param_meta import META, UNITS

    _writable(path)
    text = paramfile.pdef_xml(PARAMS, META, UNITS)
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)
    emit(args, {"file": path, "count": len(PARAMS)},
         lambda r: "wrote the documentation of %d parameters to %s (ArduPilot's apm.pdef.xml form)" % (len(PARAMS), path))


def do_param(args: argparse.Namespace) -> None:
    from roboray.ground import paramfile
    from roboray.ground.link import f32, fmt_value

    action = args.action
    rest = args.rest
    fewest, most, usage = _PARAM_USAGE[action]
    if not fewest <= len(rest) <= most:
        raise UsageError("usage: %s" % usage)
    if action == "list":
        values = _fetch_all(args)
        _cache_params(args, values)
        emit(args, {k: v[0] for k, v in values.items()},
             lambda r: paramfile.format_lines((k, fmt_value(*values[k])) for k in sorted(values)))
    elif action == "show":
        values = _cached_params() if args.cached else _fetch_all(args)
        if not args.cached:
            _cache_params(args, values)
        _param_show(args, values, rest[0] if rest else "*")
    elif action == "fetch" and not rest:
        t0 = time.monotonic()
        values = _fetch_all(args)
        _cache_params(args, values)
        took = time.monotonic() - t0
        emit(args, {"count": len(values), "seconds": round(took, 2)},
             lambda r: "received %d parameters in %.1f s" % (len(values), took))
    elif action == "pdef":
        _param_pdef(args, rest[0])
    elif action == "get" or action == "fetch":   # fetch NAME: MAVProxy's one-value fetch
        name = rest[0].upper()
        link = _connect(args)
        try:
            value, ptype = link.param_get(name)
        finally:
            link.close()
        emit(args, {name: value}, lambda r: "%s %s" % (name, fmt_value(value, ptype)))
    elif action == "set":
        name = rest[0].upper()
        try:
            value = number(rest[1])
        except argparse.ArgumentTypeError as exc:
            raise UsageError("param set %s: %s" % (name, exc))
        link = _connect(args)
        try:
            now, ptype = link.param_get(name)
            got = link.param_set(name, value, ptype)
        finally:
            link.close()
        emit(args, {name: got}, lambda r: "%s %s (was %s)" % (name, fmt_value(got, ptype), fmt_value(now, ptype)))
    elif action == "save":
        _writable(rest[0])
        values = _fetch_all(args)
        _cache_params(args, values)
        paramfile.save(rest[0], ((k, fmt_value(*values[k])) for k in sorted(values)))
        emit(args, {"file": rest[0], "count": len(values)}, lambda r: "saved %d parameters to %s" % (len(values), rest[0]))
    elif action == "load":
        _param_load(args, rest[0])
    elif action == "diff":
        # as diff(1): exit status 0 when the same, 1 when they differ; values
        # compared as the vehicle holds them (float32) and printed so that
        # two that differ never print the same
        wanted = _read_param_file(rest[0])
        values = _fetch_all(args)
        rows = []
        for name in sorted(set(wanted) | set(values)):
            ptype = values[name][1] if name in values else 9
            if name not in values:
                rows.append({"name": name, "file": wanted[name], "vehicle": None, "type": ptype})
            elif name not in wanted:
                rows.append({"name": name, "file": None, "vehicle": values[name][0], "type": ptype})
            elif f32(values[name][0]) != f32(wanted[name]):
                rows.append({"name": name, "file": wanted[name], "vehicle": values[name][0], "type": ptype})

        def shown(value: Optional[float], ptype: int) -> str:
            if value is None:
                return "--"
            if ptype != 9 and not float(value).is_integer():
                return repr(value)      # a fraction for an integer parameter: as written
            return fmt_value(value, ptype)

        def text(_: object) -> str:
            if not rows:
                return "no differences"
            return "\n".join("%-16s file %-12s vehicle %s" % (
                x["name"], shown(x["file"], x["type"]), shown(x["vehicle"], x["type"])) for x in rows)

        emit(args, [{k: x[k] for k in ("name", "file", "vehicle")} for x in rows], text)
        if rows:
            sys.stdout.flush()
            raise SystemExit(1)


def _read_param_file(path: str) -> dict:
    from roboray.ground import paramfile

    try:
        return paramfile.load(path)
    except paramfile.ParamFileError as exc:
        raise CliError(str(exc))


def _writable(path: str) -> None:
    """Refuse an output path before the link is opened, not after the work."""
    try:
        output_file(path)
    except argparse.ArgumentTypeError as exc:
        raise UsageError(str(exc))


def _unchanged(err: Exception) -> str:
    sep = "\n" if len(getattr(err, "problems", ())) > 1 else "; "
    return "%s%snothing was changed (--partial sets the good lines only)" % (err, sep)


def _param_load(args: argparse.Namespace, path: str) -> None:
    """Check the whole file against the vehicle, then set what differs; all or nothing.

    Nothing is sent before every line has passed: the file (size,
    encoding, syntax, names given twice), then each name and value
    against the vehicle's list (does it exist, is an integer parameter
    given an integer) and the firmware's declarations (range, read-only).
    Should the vehicle still refuse one, or the link fail, the ones
    already changed are set back. ``--partial`` sets the good lines and
    lists the others."""
    from roboray.firmware.app import PARAMS
    from roboray.ground import paramfile
    from roboray.ground.link import f32

    try:
        wanted, where, problems = paramfile.load_lines(path)
    except paramfile.ParamFileError as exc:
        raise CliError("%s; nothing was changed" % exc)
    if not wanted and not problems:
        raise CliError("%s: no parameters in the file; nothing was changed" % path)
    if problems and not args.partial:
        raise CliError(_unchanged(paramfile.ParamFileError(problems)))
    decls = {d[0]: d for d in PARAMS}
    link = _connect(args)
    changed: list = []
    same = 0
    try:
        values = link.param_list(args.param_timeout)
        todo = []
        for name, value in wanted.items():
            at = "%s:%d: " % (path, where[name])
            if name not in values:
                problems.append(at + "%s is not a parameter of the vehicle" % name)
            elif f32(values[name][0]) == f32(value):
                same += 1
            else:
                why = paramfile.check_value(name, value, values[name][1], decls.get(name))
                if why is None:
                    todo.append(name)
                else:
                    problems.append(at + why)
        if problems and not args.partial:
            raise CliError(_unchanged(paramfile.ParamFileError(problems)))
        try:
            for name in todo:
                link.param_set(name, wanted[name], values[name][1])
                changed.append(name)
        except CliError as exc:
            lost = []
            for name in reversed(changed):
                try:
                    link.param_set(name, values[name][0], values[name][1])
                except CliError:
                    lost.append(name)
            if lost:
                raise CliError("%s; setting back the %d changed before it failed for %s: check them"
                               % (exc, len(changed), ", ".join(sorted(lost))))
            raise CliError("%s; the %d parameter(s) changed before it were set back: nothing was changed"
                           % (exc, len(changed)))
    finally:
        link.close()
    result = {"file": path, "changed": changed, "unchanged": same, "skipped": problems}

    def text(r: dict) -> str:
        lines = ["loaded %s: %d changed, %d already equal" % (path, len(changed), same)]
        if problems:
            lines[0] += ", %d line(s) skipped (--partial):" % len(problems)
            lines += ["  " + x for x in problems]
        return "\n".join(lines)

    emit(args, result, text)


# --------------------------------------------------------------- signing
def do_signing(args: argparse.Namespace) -> None:
    """MAVProxy's ``signing setup PASSPHRASE`` and ``signing remove``.

    ``--key``/``--key-file`` give the vehicle's current key (none: it has
    none). Setup sends SETUP_SIGNING with the passphrase's key and our wall
    clock, remove an all-zero key; either is confirmed by an exchange under
    the new key (``Link.change_key``)."""
    from roboray.ground.link import key_from_passphrase

    if args.action == "setup":
        if len(args.rest) != 1 or not args.rest[0]:
            raise UsageError("usage: signing setup PASSPHRASE (the vehicle's current key, if any, with --key)")
        new: Optional[bytes] = key_from_passphrase(args.rest[0])
    else:
        if args.rest:
            raise UsageError("usage: signing remove --key PASSPHRASE (the vehicle's current key)")
        new = None
    link = _connect(args)
    try:
        if link.key is None and link.vehicle_signs():
            raise CliError("the vehicle signs its frames: it has a key; give the current one with --key or --key-file")
        if new is None and link.key is None:
            result = {"signing": "off", "system": link.target_system, "changed": False}
            emit(args, result, lambda r: "vehicle %d has no signing key: nothing to remove" % link.target_system)
            return
        link.change_key(new, timeout=args.ack_timeout)
    finally:
        link.close()
    sysid = link.target_system
    if new is not None:
        emit(args, {"signing": "on", "system": sysid, "changed": True},
             lambda r: "signing key set on vehicle %d: it now obeys only frames signed with it "
                       "(give it with --key)" % sysid)
    else:
        emit(args, {"signing": "off", "system": sysid, "changed": True},
             lambda r: "signing removed on vehicle %d: it takes unsigned frames" % sysid)


# ----------------------------------------------------------------- watch
def do_watch(args: argparse.Namespace) -> None:
    """Live view; redraws in place on a terminal, one line a second otherwise."""
    from roboray.ground.link import Link, LinkError
    from roboray.ground.watch import State, one_line, render

    tty = sys.stdout.isatty() and not args.plain
    state = State(lost_after_s=args.lost_after)
    link = Link(_master(args), args.baudrate, args.source_system, _key(args), connect_timeout=args.timeout)
    link.on_message = state.update
    end = math.inf if args.duration is None else time.monotonic() + args.duration
    next_draw = 0.0
    if tty:
        sys.stdout.write("\x1b[?25l\x1b[2J")  # hide the cursor, clear once
    try:
        while time.monotonic() < end:
            try:
                link.recv(0.05)
            except LinkError:
                time.sleep(0.5)  # the port came and went: keep showing "link lost"
            now = time.monotonic()
            if now < next_draw:
                continue
            if tty:
                next_draw = now + 0.25
                lines = render(state, link.describe(), now)
                sys.stdout.write("\x1b[H" + "".join(line + "\x1b[K\n" for line in lines) + "\x1b[J")
            else:
                next_draw = now + 1.0
                sys.stdout.write(time.strftime("%H:%M:%S ") + one_line(state, now) + "\n")
            sys.stdout.flush()
    finally:
        if tty:
            sys.stdout.write("\x1b[?25h")
            sys.stdout.flush()
        link.close()


# ------------------------------------------------------------------- logs
def do_log(args: argparse.Namespace) -> None:
    action = args.action
    if action in ("record", "plot", "download") and args.target is None:
        raise UsageError("log %s needs %s" % (action, "a log number (or latest)" if action == "download"
                                               else "FILE"))
    if action in ("list", "erase") and args.target is not None:
        raise UsageError("log %s takes no argument (got %r)" % (action, args.target))
    args.file = args.target
    {"record": _log_record, "plot": _log_plot, "list": _log_list, "download": _log_download,
     "erase": _log_erase}[action](args)


def _log_list(args: argparse.Namespace) -> None:
    from roboray.ground.logs import list_logs

    link = _connect(args)
    try:
        entries = list_logs(link)
    finally:
        link.close()

    def text(rows: list) -> str:
        if not rows:
            return "no logs on the vehicle"
        return "\n".join(["  id      size"] + ["%4d %9d" % (r["id"], r["size"]) for r in rows])

    emit(args, [e.as_dict() for e in entries], text)


def _log_download(args: argparse.Namespace) -> None:
    from roboray.ground.logs import download, list_logs
    from roboray.sim import progress

    which = args.target
    if which != "latest":
        try:
            number = int(which)
        except ValueError:
            number = 0
        if number < 1:
            raise UsageError("log download: expected a log number >= 1 or 'latest', got %r" % which)
    link = _connect(args)
    try:
        entries = list_logs(link)
        if not entries:
            raise CliError("no logs on the vehicle")
        if which == "latest":
            entry = entries[-1]
        else:
            found = [e for e in entries if e.id == number]
            if not found:
                raise CliError("no log %d on the vehicle (it has %s)" % (number, ", ".join(str(e.id) for e in entries)))
            entry = found[0]
        out = args.out or "%08d.BIN" % entry.id
        _writable(out)
        with progress.bar(args, entry.size, "log %d" % entry.id, unit="B") as b:
            done = [0]

            def moved(received: int, size: int) -> None:
                b.update(received - done[0])
                done[0] = received

            result = download(link, entry, out, timeout=args.data_timeout, progress=moved)
    finally:
        link.close()
    emit(args, result, lambda r: "log %d: %d bytes to %s in %.1f s%s" % (
        r["id"], r["size"], r["path"], r["seconds"],
        " (resumed after %d bytes)" % r["resumed_bytes"] if r["resumed_bytes"] else ""))


def _log_erase(args: argparse.Namespace) -> None:
    from roboray.ground.logs import erase_logs, list_logs

    link = _connect(args)
    try:
        n = len(list_logs(link))
        erase_logs(link)
    finally:
        link.close()
    emit(args, {"erased": n}, lambda r: "erased %d log(s)" % n)


def _log_record(args: argparse.Namespace) -> None:
    from roboray.ground.tlog import TlogWriter

    _writable(args.file)
    _master(args)   # no link given: said before anything is written
    link = _connect(args)
    count = 0
    end = math.inf if args.duration is None else time.monotonic() + args.duration
    tmp = args.file
    try:
        with open(tmp, "wb") as f:
            writer = TlogWriter(f)
            link.on_message = lambda m: writer.write(m.get_msgbuf())
            try:
                while time.monotonic() < end:
                    link.recv(0.1)
                    f.flush()
            except KeyboardInterrupt:
                pass
            count = writer.frames
    finally:
        link.close()
    emit(args, {"file": args.file, "frames": count}, lambda r: "recorded %d frames to %s" % (count, args.file))


def _log_plot(args: argparse.Namespace) -> None:
    from roboray.ground import binplot, plot

    if not args.out:
        raise UsageError("log plot needs --out FILE.png")
    with open(args.file, "rb") as f:
        data = f.read()
    draw = binplot.plot if binplot.is_dataflash(data) else plot.plot
    try:
        counts = draw(data, args.out, title=os.path.basename(args.file))
    except ValueError as exc:
        raise CliError("%s: %s" % (args.file, exc))
    emit(args, {"out": args.out, "samples": counts}, lambda r: "wrote %s" % args.out)


def _message_types() -> set:
    """Every message name a tlog can hold that we know: ours and pymavlink's common dialect."""
    from pymavlink.dialects.v20 import common

    from roboray.shared.mavlink.messages import NAME, TABLE

    return {e[NAME] for e in TABLE.values()} | {c.msgname for c in common.mavlink_map.values()}


def do_tlog_dump(args: argparse.Namespace) -> None:
    """Decode a tlog with the board codec: one JSON object a message (JSON lines).

    Exit 1, after printing what could be read, when the file holds no
    record, when ``--types`` matched none, or when damage was skipped
    (the line on stderr says where)."""
    from roboray.ground import tlog
    from roboray.ground.link import key_from_passphrase

    types = None
    if args.types:
        types = {t.upper() for t in args.types}
        known = _message_types()
        unknown = sorted(t for t in types if t not in known and not t.startswith("UNKNOWN_"))
        if unknown:
            raise UsageError("--types: no message type %s (e.g. ATTITUDE, HEARTBEAT, SYS_STATUS)"
                             % ", ".join(unknown))
    with open(args.file, "rb") as f:
        data = f.read()
    if not data:
        raise CliError("%s is empty" % args.file)
    dec = tlog.Decoder(key_from_passphrase(args.key) if args.key else None)
    damage = tlog.Damage()
    out = sys.stdout
    n = matched = 0
    for t_us, frame in tlog.records(data, damage):
        n += 1
        m = dec.decode(frame)
        if types and m["mavpackettype"] not in types:
            continue
        matched += 1
        if args.json:
            m = {"timestamp": t_us / 1e6, **m}
            out.write(json.dumps(_finite(m)) + "\n")
        else:
            fields = ", ".join("%s: %s" % (k, v) for k, v in m.items() if k != "mavpackettype")
            out.write("%s %s {%s}\n" % (time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(t_us / 1e6)),
                                         m["mavpackettype"], fields))
    out.flush()
    if n == 0:
        raise CliError("%s: no tlog record in its %d bytes (a tlog is 8-byte timestamps, each followed by a "
                       "MAVLink frame): not a tlog" % (args.file, len(data)))
    hurt = damage.describe(args.file, n)
    if types and not matched:
        raise CliError("%s: none of its %d messages is %s%s" % (args.file, n, " or ".join(sorted(types)),
                                                                 "; " + hurt if hurt else ""))
    if hurt:
        raise CliError(hurt)


# ------------------------------------------------------------------ demo
def do_demo_vehicle(args: argparse.Namespace) -> None:
    """The board endpoint on MicroPython behind a pseudo-terminal, until Ctrl-C."""
    from roboray.ground.vehicle import PtyVehicle

    key = _key(args)
    with PtyVehicle(key=key, sysid=args.sysid, animate=not args.still) as v:
        sys.stdout.write(v.device + "\n")
        sys.stdout.flush()
        end = math.inf if args.duration is None else time.monotonic() + args.duration
        while time.monotonic() < end and v.error is None:
            time.sleep(0.2)
        if v.error is not None:
            raise CliError("vehicle stopped: %s" % str(v.error).splitlines()[-1])


def build_parser():
    parser, sub = make_parser("roboray-ground", "RoboRay ground station (MAVLink 2 over a serial radio or UDP).")
    _link_options(parser, top=True)
    p = command(sub, "ports", do_ports, "list the serial ports a radio could be on")
    add_json(p)

    p = command(sub, "status", do_status, "the vehicle's state, once")
    _link_options(p)
    p.add_argument("--listen", type=positive, default=1.5, metavar="S",
                   help="seconds of telemetry to gather (default 1.5)")
    add_json(p)

    p = command(sub, "watch", do_watch, "live view of the vehicle, redrawn in place")
    _link_options(p)
    p.add_argument("--duration", type=positive, default=None, metavar="S", help="stop after this many seconds")
    p.add_argument("--plain", action="store_true", help="line output even on a terminal")
    p.add_argument("--lost-after", type=positive, default=3.0, metavar="S",
                   help="seconds without a heartbeat shown as link lost (default 3)")

    ack = dict(type=positive, default=3.0, metavar="S", help="seconds to wait for COMMAND_ACK (default 3)")
    for name, handler, text, force in (
            ("arm", do_arm, "arm the vehicle in its present mode (PASSIVE after a boot); the mode stays",
             "arm without the vehicle's pre-arm checks (MAVLink's force code 21196)"),
            ("disarm", do_disarm, "disarm the vehicle (servos to the safe position; the mode stays)",
             "send MAVLink's force code 21196 as well; this vehicle never refuses to disarm, so it changes "
             "nothing")):
        p = command(sub, name, handler, text)
        _link_options(p)
        p.add_argument("--force", action="store_true", help=force)
        p.add_argument("--ack-timeout", **ack)
        add_json(p)

    p = command(sub, "reboot", do_reboot, "restart the vehicle (disarmed only; it saves its parameters first), so "
                "what it reads only at start-up takes effect")
    _link_options(p)
    p.add_argument("--wait", type=positive, default=None, metavar="S",
                   help="wait up to S seconds for the vehicle to be heard again after its restart")
    p.add_argument("--ack-timeout", **ack)
    add_json(p)

    p = command(sub, "mode", do_mode, "switch flight mode (PASSIVE, ATTITUDE, VELOCITY, TARGET, FAILSAFE), "
                "armed or not")
    p.add_argument("name", metavar="NAME",
                   help="the mode, in any case: PASSIVE, ATTITUDE, VELOCITY, TARGET or FAILSAFE, or the name "
                        "MAVProxy and QGroundControl show for it: MANUAL, STABILIZE, GUIDED, AUTO or SURFACE "
                        "(armed, TARGET needs a target set first; FAILSAFE a failsafe chose is left once its "
                        "cause has cleared)")
    _link_options(p)
    p.add_argument("--ack-timeout", **ack)
    add_json(p)

    p = command(sub, "target", do_target,
                "set the landing target, metres north and east of the release point; one beyond the reach "
                "(best glide ratio 0.49 times the bottom's depth) is refused")
    p.add_argument("north", type=number, metavar="NORTH", help="metres north of the release point (negative: south)")
    p.add_argument("east", type=number, metavar="EAST", help="metres east of the release point (negative: west)")
    p.add_argument("--down", type=positive, default=None, metavar="D",
                   help="the bottom's depth at the target, metres below the surface, > 0 (default: the "
                        "vehicle's CTL_DEPTH_M parameter)")
    _link_options(p)
    p.add_argument("--ack-timeout", **ack)
    add_json(p)

    p = command(sub, "wp", do_wp,
                "the landing target as a mission, as MAVProxy's wp: list it, set it (metres north and east of "
                "the release point; one beyond the reach is refused) or clear it")
    p.add_argument("action", choices=("list", "set", "clear"),
                   help="list: home (item 0) and the target (item 1); set NORTH EAST: upload them; clear: no target")
    p.add_argument("rest", nargs="*", metavar="ARG",
                   help="set: NORTH EAST, metres north and east of the release point (negative: south, west)")
    p.add_argument("--down", type=positive, default=None, metavar="D",
                   help="set: the bottom's depth at the target, metres below the surface, > 0 (default: the "
                        "vehicle's CTL_DEPTH_M parameter)")
    _link_options(p)
    p.add_argument("--ack-timeout", type=positive, default=1.5, metavar="S",
                   help="seconds to wait for each answer before asking again, up to five more times "
                        "(default 1.5, MAVLink's)")
    add_json(p)

    p = command(sub, "param", do_param, "list, get, set, show, fetch, save, load or diff parameters "
                "(ArduPilot file format); pdef writes their documentation (apm.pdef.xml)")
    p.add_argument("action", choices=("list", "get", "set", "show", "fetch", "save", "load", "diff", "pdef"))
    p.add_argument("rest", nargs="*", metavar="ARG", help="NAME, NAME VALUE, PATTERN or FILE")
    _link_options(p)
    p.add_argument("--param-timeout", type=float, default=10.0, help="seconds for a full parameter list")
    p.add_argument("--partial", action="store_true",
                   help="load: set the file's good lines and list the bad ones (default: all or nothing)")
    p.add_argument("-v", "--verbose", dest="describe", action="store_true",
                   help="show: with units, range, values and description")
    p.add_argument("--cached", action="store_true",
                   help="show: from the list the last fetch, list, show or save received (no link)")
    add_json(p)

    p = command(sub, "signing", do_signing,
                "set the vehicle's signing key from a passphrase (setup PASSPHRASE) or remove it (remove)")
    p.add_argument("action", choices=("setup", "remove"))
    p.add_argument("rest", nargs="*", metavar="PASSPHRASE", help="setup: the new key's passphrase")
    _link_options(p)
    p.add_argument("--ack-timeout", type=float, default=6.0,
                   help="seconds for the vehicle to confirm the change (default 6)")
    add_json(p)

    p = command(sub, "log", do_log, "the vehicle's on-board logs (list, download, erase), tlogs (record), plots")
    p.add_argument("action", choices=("list", "download", "erase", "record", "plot"),
                   help="list: the logs on the vehicle; download N|latest: fetch one (.BIN), resuming a "
                        "download that was cut; erase: remove every log (disarmed); record FILE.tlog: write "
                        "what the vehicle sends; plot FILE: draw a .BIN or a .tlog to --out")
    p.add_argument("target", nargs="?", metavar="N|FILE",
                   help="download: the log's number or 'latest'; record, plot: the file")
    p.add_argument("--out", type=output_file, metavar="FILE",
                   help="plot: the PNG to write; download: the file (default NNNNNNNN.BIN here)")
    p.add_argument("--data-timeout", type=positive, default=10.0, metavar="S",
                   help="download: give up after this long without new data; the part kept resumes (default 10)")
    p.add_argument("--duration", type=positive, default=None, metavar="S", help="record: stop after this many seconds")
    _link_options(p)
    add_json(p)

    tl = sub.add_parser("tlog", help="read tlogs with the board's own codec", description="read tlogs with the board's own codec")
    tl_sub = tl.add_subparsers(title="actions", metavar="ACTION", parser_class=type(parser))
    p = command(tl_sub, "dump", do_tlog_dump, "decode a tlog: one JSON object per message with --json")
    p.add_argument("file", metavar="FILE", help="the tlog to read")
    p.add_argument("--key", metavar="PASSPHRASE", help="check signatures with this passphrase's key")
    p.add_argument("--types", nargs="+", metavar="TYPE", help="only these message types")
    add_json(p)

    from roboray.ground import fixes_command

    fixes_command.register(sub, _link_options, _connect)

    p = command(sub, "demo-vehicle", do_demo_vehicle,
                "serve the board endpoint (MicroPython) behind a pseudo-terminal; prints its path")
    p.add_argument("--sysid", type=_system_id, default=1, help="the vehicle's MAVLink system id (default 1)")
    p.add_argument("--key", metavar="PASSPHRASE", default=argparse.SUPPRESS,
                   help="the vehicle's signing key, from PASSPHRASE (default: none)")
    p.add_argument("--key-file", metavar="FILE", default=argparse.SUPPRESS,
                   help="read the key's passphrase from FILE's first line")
    p.add_argument("--still", action="store_true", help="hold the telemetry still (default: a scripted descent)")
    p.add_argument("--duration", type=positive, default=None, metavar="S", help="stop after this many seconds")
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    return run(build_parser(), argv)


if __name__ == "__main__":
    raise SystemExit(main())
