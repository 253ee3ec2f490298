"""ArduPilot's parameter file format, so files move between tools.

One parameter a line: ``NAME VALUE`` (spaces or tabs) or ``NAME,VALUE``
(Mission Planner); ``#`` starts a comment; blank lines are ignored. We
write ``NAME VALUE`` padded to a column, as MAVProxy's ``param save`` does.
"""

from __future__ import annotations

import math
import os
import re
from typing import Iterable

_NAME = re.compile(r"^[A-Za-z0-9_]{1,16}$")


class ParamFileError(ValueError):
    """A line that is not ``NAME VALUE``; the message names file and line."""


def parse(text: str, source: str = "<text>") -> dict[str, float]:
    values: dict[str, float] = {}
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = [p for p in re.split(r"[,\s]+", line) if p]
        if len(parts) != 2:
            raise ParamFileError("%s:%d: expected NAME VALUE, got %r" % (source, lineno, raw.strip()))
        name, text_value = parts
        if not _NAME.match(name):
            raise ParamFileError("%s:%d: %r is not a parameter name" % (source, lineno, name))
        try:
            value = float(text_value)
        except ValueError:
            raise ParamFileError("%s:%d: %s has value %r, not a number" % (source, lineno, name, text_value))
        if not math.isfinite(value):
            raise ParamFileError("%s:%d: %s has value %r, not a finite number" % (source, lineno, name, text_value))
        values[name] = value
    return values


def load(path: str) -> dict[str, float]:
    with open(path, encoding="utf-8") as f:
        return parse(f.read(), path)


def format_lines(values: Iterable[tuple[str, str]]) -> str:
    return "".join("%-16s %s\n" % (name, value) for name, value in values)


def save(path: str, values: Iterable[tuple[str, str]]) -> None:
    """Write atomically: a temporary file renamed over the target."""
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(format_lines(values))
    os.replace(tmp, path)
