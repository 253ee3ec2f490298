"""Progress with an ETA for the jobs that take more than a few seconds.

A bar (tqdm) on stderr when stderr is a terminal; nothing at all when it
is not (a pipe, a file, CI) or with ``--json``, so what a script reads is
the same with and without it. Log lines written while a bar is up go above
it instead of through it.

A job hands its analyses the bar's ``update(n)``; an analysis that is
called without one takes :data:`QUIET`. Units either count what the user
asked for (flights, seeds, runs) or, where the steps of a job cost very
different times, are weights measured once, so that the ETA holds; those
bars show a percentage instead of a count.
"""

from __future__ import annotations

import contextlib
import sys
from typing import Any, Iterator, Optional


class _Quiet:
    """What an analysis updates when nobody watches it."""

    def update(self, n: float = 1) -> None:
        pass

    def set_postfix_str(self, text: str = "", refresh: bool = True) -> None:
        pass


QUIET = _Quiet()

#: A bar whose units are weights: a percentage, what the job is doing now.
_WEIGHTED = "{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}{postfix}"
#: A bar counting things: how many of how many.
_COUNTED = "{desc}: {n_fmt}/{total_fmt} {unit}|{bar}| {elapsed}<{remaining}{postfix}"


def shown(args: Any = None) -> bool:
    """A bar is drawn: stderr is a terminal and no JSON was asked for."""
    if args is not None and getattr(args, "json", False):
        return False
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):   # closed or replaced by something without a terminal
        return False


@contextlib.contextmanager
def bar(args: Any, total: float, what: str, unit: Optional[str] = None) -> Iterator[Any]:
    """A progress bar over ``total`` units while the block runs.

    ``unit`` names what is counted (``"flights"``); without it the units
    are weights and the bar shows a percentage."""
    if not shown(args):
        yield QUIET
        return
    from tqdm import tqdm
    from tqdm.contrib.logging import logging_redirect_tqdm

    # a counted unit is seconds of work: every one is drawn; weights come
    # in small steps, drawn ten times a second at most
    look = {"bar_format": _COUNTED, "unit": unit, "mininterval": 0.0, "miniters": 1} if unit else \
        {"bar_format": _WEIGHTED}
    with logging_redirect_tqdm(), tqdm(total=total, desc=what, file=sys.stderr, leave=False, smoothing=0.1,
                                       **look, **_size()) as b:
        yield b


def _size() -> dict:
    """The terminal's width, followed as it changes; a terminal that has no
    size yet (a fresh pseudo-terminal: 0 x 0, where tqdm would draw
    nothing) is taken as 80 x 24."""
    import os

    try:
        size = os.get_terminal_size(sys.stderr.fileno())
        columns, lines = size.columns, size.lines
    except (OSError, ValueError, AttributeError):
        columns = lines = 0
    if columns > 0 and lines > 0:
        return {"dynamic_ncols": True}
    return {"ncols": 80, "nrows": 24}
