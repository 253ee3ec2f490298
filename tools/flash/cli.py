"""``roboray-flash``: build the board code and put it on a board."""

from __future__ import annotations

import argparse
import signal
import sys
from typing import Optional, Sequence

from roboray.tools.cli import command, make_parser, run


def do_virtual_board(args: argparse.Namespace) -> None:
    """Serve a MicroPython board on a pseudo-terminal until interrupted."""
    from roboray.tools.micropython.virtual_board import VirtualBoard

    board = VirtualBoard(fs_dir=args.fs).start()
    # The device path is the first line, so scripts can read it and connect.
    sys.stdout.write(board.device + "\n")
    sys.stdout.flush()
    signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(KeyboardInterrupt()))
    try:
        status = board.wait()
    except KeyboardInterrupt:
        status = 0
    finally:
        board.close()
    if status not in (0, None):
        raise SystemExit("virtual board interpreter exited with status %d" % status)


def build_parser():
    parser, sub = make_parser("roboray-flash", "Build the RoboRay board code and deploy it to a board.")
    p = command(sub, "virtual-board", do_virtual_board,
                "serve a MicroPython board on a pseudo-terminal (prints its device path first)")
    p.add_argument("--fs", metavar="DIR", help="keep the board's file system in DIR (survives restarts)")
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    return run(build_parser(), argv)


if __name__ == "__main__":
    raise SystemExit(main())
