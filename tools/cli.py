"""Conventions shared by the three console scripts.

- ``--help`` on every command; subcommands dispatch to ``do_<name>(args)``.
- Exit 0 on success, 2 on a usage error, 1 on a failure, 130 on Ctrl-C.
- Every foreseeable failure is one line on stderr, ``prog: error: ...``,
  never a traceback (``--debug`` shows it).
- Commands that report figures accept ``--json`` and then print exactly one
  JSON document on stdout, its figures at their meaningful digits
  (``tools/jsonround.py``); log lines always go to stderr.
"""

from __future__ import annotations

import argparse
import errno
import json
import logging
import math
import re
import sys
from typing import Any, Callable, Optional, Sequence

log = logging.getLogger("roboray")


class CliError(Exception):
    """A foreseeable failure, reported as one line; exit status 1."""

    exit_code = 1


class UsageError(CliError):
    """Arguments that make no sense together; exit status 2."""

    exit_code = 2


#: What argparse takes for a negative number, so that ``--target -1.5,-1``,
#: ``--v0 -0.1,0,0``, ``--down -2e-1`` and ``target -2 -1`` give the option
#: (or the positional) its value: a ``-`` followed by a digit, or by a point
#: and a digit. argparse's own (``^-\d+$|^-\d*\.\d+$``, widened to
#: exponents in Python 3.14) takes a comma list for an unknown option and
#: says "expected one argument". It only applies while no option string
#: itself looks like a negative number, which none of ours does.
NEGATIVE_NUMBER = re.compile(r"^-\.?\d")


class Parser(argparse.ArgumentParser):
    """argparse with a one-line usage error and exit status 2, and values
    that start with a minus sign (negative numbers and lists of them)."""

    def __init__(self, *args: Any, **kw: Any) -> None:
        super().__init__(*args, **kw)
        # argparse consults this attribute on the parser that parses (each
        # subcommand has its own Parser); tests/test_cli.py holds the effect.
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write("%s: error: %s (see %s --help)\n" % (self.prog, message, self.prog))
        raise SystemExit(2)


def add_json(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print one JSON document on stdout")


def floats(text: str, count: Optional[int] = None, name: str = "value") -> list[float]:
    """Parse ``"1,2,3"``; raises argparse.ArgumentTypeError naming the problem."""
    parts = [p.strip() for p in text.split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError("%s %r is not a comma-separated list of numbers" % (name, text))
    if count is not None and len(values) != count:
        raise argparse.ArgumentTypeError("%s %r needs %d numbers, got %d" % (name, text, count, len(values)))
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError("%s %r has a value that is not finite" % (name, text))
    return values


def number(text: str) -> float:
    """A finite float argument."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("%r is not a number" % text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError("%r is not a finite number" % text)
    return value


def output_file(text: str) -> str:
    """A file to write: its folder must exist and be writable, and it must not
    be a folder itself. Checked when the arguments are parsed, so a long run
    never ends on a path that could not be written."""
    import os

    if not text:
        raise argparse.ArgumentTypeError("an empty file name")
    folder = os.path.dirname(os.path.abspath(text))
    if not os.path.isdir(folder):
        raise argparse.ArgumentTypeError("%s: no folder %s to write it in" % (text, folder))
    if os.path.isdir(text):
        raise argparse.ArgumentTypeError("%s is a folder, not a file" % text)
    if not os.access(folder, os.W_OK | os.X_OK) or (os.path.exists(text) and not os.access(text, os.W_OK)):
        raise argparse.ArgumentTypeError("%s: not writable here (permissions)" % text)
    return text


def positive(text: str) -> float:
    value = number(text)
    if value <= 0:
        raise argparse.ArgumentTypeError("%r must be greater than 0" % text)
    return value


def best_glide_ratio() -> float:
    """The allocation table's best glide ratio (0.49, between two wings)."""
    from roboray.shared.control import allocation_table as T

    return float(max(T.RATIO_MAX))


def glide_reach(depth: float, release_depth: float = 0.0) -> float:
    """How far (m, horizontally) a target landing can go: the best glide
    ratio times the height from the release to the bottom."""
    return best_glide_ratio() * max(0.0, depth - release_depth)


def check_target(north: float, east: float, depth: float, release_depth: float = 0.0,
                 whose: str = "") -> float:
    """Refuse (exit 2) a target beyond :func:`glide_reach`; return its
    distance. The one reach check of ``fly``, ``sil`` and ``roboray-ground
    target``; ``whose`` says where the depth came from when not the
    command's own ``--depth``."""
    distance = math.hypot(north, east)
    reach = glide_reach(depth, release_depth)
    if distance > reach:
        raise UsageError("target %.2f m north, %.2f m east is %.2f m away, beyond the reach of a glide from "
                         "%.2f m deep to a bottom at %.1f m%s: %.2f m (best glide ratio %.2f)"
                         % (north, east, distance, release_depth, depth, whose, reach,
                            best_glide_ratio()))
    return distance


def emit(args: argparse.Namespace, result: Any, text: Optional[Callable[[Any], str]] = None) -> None:
    """Print a command's result: one JSON document with ``--json``, else text."""
    if getattr(args, "json", False):
        from roboray.tools.jsonround import rounded

        json.dump(rounded(result), sys.stdout, indent=2, sort_keys=True, default=_jsonable)
        sys.stdout.write("\n")
    elif text is not None:
        sys.stdout.write(text(result).rstrip("\n") + "\n")
    elif isinstance(result, dict):
        width = max((len(k) for k in result), default=0)
        for key in sorted(result):
            sys.stdout.write("%-*s  %s\n" % (width, key, _fmt(result[key])))
    sys.stdout.flush()


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return "%.6g" % value
    return str(value)


def _jsonable(o: Any) -> Any:
    try:
        import numpy as np

        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, np.ndarray):
            return o.tolist()
    except ImportError:  # pragma: no cover - numpy is a dependency
        pass
    raise TypeError("%r is not JSON serialisable" % (o,))


def _describe(exc: BaseException) -> Optional[str]:
    """One line for the failures users can cause; None for real bugs."""
    if isinstance(exc, CliError):
        return str(exc)
    if isinstance(exc, FileNotFoundError):
        return "no such file: %s" % (exc.filename or exc)
    if isinstance(exc, PermissionError):
        return "permission denied: %s" % (exc.filename or exc)
    if isinstance(exc, IsADirectoryError):
        return "is a directory: %s" % (exc.filename or exc)
    if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EROFS):
        return "cannot write %s: %s" % (exc.filename or "", exc.strerror)
    try:
        import serial

        if isinstance(exc, serial.SerialException):
            return "serial port: %s" % exc
    except ImportError:  # pragma: no cover - pyserial is a dependency
        pass
    try:
        from roboray.tools.micropython import MicroPythonUnavailable

        if isinstance(exc, MicroPythonUnavailable):
            return str(exc)
    except ImportError:  # pragma: no cover
        pass
    return None


def run(parser: argparse.ArgumentParser, argv: Optional[Sequence[str]] = None) -> int:
    """Parse, dispatch to ``args.handler`` and turn failures into exit codes."""
    args = parser.parse_args(argv)
    level = logging.DEBUG if args.verbose else logging.WARNING if args.quiet else logging.INFO
    logging.basicConfig(level=level, format="%(name)s: %(message)s", stream=sys.stderr)
    handler = getattr(args, "handler", None)
    if handler is None:
        parser.print_help(sys.stderr)
        return 2
    try:
        handler(args)
        return 0
    except KeyboardInterrupt:
        sys.stderr.write("%s: interrupted\n" % parser.prog)
        return 130
    except BrokenPipeError:
        return 0
    except Exception as exc:  # one line for the foreseeable, a traceback for bugs
        message = _describe(exc)
        if message is None or args.debug:
            raise
        sys.stderr.write("%s: error: %s\n" % (parser.prog, message))
        return getattr(exc, "exit_code", 1)


def make_parser(prog: str, description: str) -> tuple[Parser, Any]:
    """Top-level parser with the common flags, and its subparsers object."""
    parser = Parser(prog=prog, description=description)
    parser.add_argument("-v", "--verbose", action="store_true", help="log debugging detail on stderr")
    parser.add_argument("-q", "--quiet", action="store_true", help="log only warnings and errors")
    parser.add_argument("--debug", action="store_true", help="show a traceback on failure")
    try:
        from importlib.metadata import version

        parser.add_argument("--version", action="version", version="%(prog)s " + version("roboray"))
    except Exception:  # noqa: BLE001 - running from a source tree without metadata
        pass
    sub = parser.add_subparsers(title="commands", metavar="COMMAND", parser_class=Parser)
    return parser, sub


def command(sub: Any, name: str, handler: Callable[[argparse.Namespace], Any], help: str, **kw: Any) -> Parser:
    """Add a subcommand whose ``handler`` is called with the parsed args."""
    p = sub.add_parser(name, help=help, description=help, **kw)
    p.set_defaults(handler=handler)
    return p
