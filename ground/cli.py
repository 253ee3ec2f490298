"""``roboray-ground``: the ground station."""

from __future__ import annotations

import argparse
from typing import Optional, Sequence

from roboray.tools.cli import add_json, command, emit, make_parser, run


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


def build_parser():
    parser, sub = make_parser("roboray-ground", "RoboRay ground station (MAVLink 2 over a serial radio or UDP).")
    p = command(sub, "ports", do_ports, "list the serial ports a radio could be on")
    add_json(p)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    return run(build_parser(), argv)


if __name__ == "__main__":
    raise SystemExit(main())
