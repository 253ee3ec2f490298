"""Series drawn as lines that break where the data does: a gap in the
records, or a heading that wraps from 359 to 0 degrees.

A line drawn straight across a gap says the value moved smoothly through
a time nothing was recorded (a full ring on the vehicle, a radio fade); a
heading drawn across its wrap paints a vertical stroke through the whole
axis. Matplotlib breaks a line at a NaN, so a NaN goes in at each break.
"""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

#: A gap is a step longer than this many times the series' usual step ...
GAP_STEPS = 3.0
#: ... and longer than this (s): a 1 Hz record's jitter is no gap.
MIN_GAP_S = 0.5


def usual_step(t: Sequence[float]) -> float:
    """The median time between samples (0 with fewer than two)."""
    t = np.asarray(t, float)
    if t.size < 2:
        return 0.0
    return float(np.median(np.diff(t)))


def gaps(t: Sequence[float], step: Optional[float] = None) -> list[tuple[float, float]]:
    """(last sample before, first sample after) of each gap in ``t``."""
    t = np.asarray(t, float)
    if t.size < 2:
        return []
    step = usual_step(t) if step is None else step
    limit = max(GAP_STEPS * step, MIN_GAP_S)
    d = np.diff(t)
    return [(float(t[i]), float(t[i + 1])) for i in np.nonzero(d > limit)[0]]


def broken(t: Sequence[float], y: Sequence[float], wrap: Optional[float] = None,
           step: Optional[float] = None) -> tuple[np.ndarray, np.ndarray]:
    """(t, y) with a NaN between two samples a gap apart and, with ``wrap``
    (the period, 360 for a heading in degrees), between two that jump by
    more than half of it."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    if t.size < 2:
        return t, y
    step = usual_step(t) if step is None else step
    cut = np.diff(t) > max(GAP_STEPS * step, MIN_GAP_S)
    if wrap is not None:
        cut |= np.abs(np.diff(y)) > wrap / 2.0
    at = np.nonzero(cut)[0] + 1
    return np.insert(t, at, np.nan), np.insert(y, at, np.nan)
