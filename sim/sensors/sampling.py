"""Reading a ``Truth`` at a sensor's own sample instants."""

from __future__ import annotations

import numpy as np


def interpolate(t: np.ndarray, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Linear interpolation of ``values`` (N,) or (N, D) sampled at ``t`` (N,)."""
    values = np.asarray(values, dtype=float)
    at = np.asarray(at, dtype=float)
    if values.ndim == 1:
        return np.interp(at, t, values)
    return np.stack([np.interp(at, t, values[:, i]) for i in range(values.shape[1])], axis=1)


def interpolate_quaternion(t: np.ndarray, q: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Normalised linear interpolation of unit quaternions (N, 4), after
    making consecutive samples the same hemisphere (q and -q are one
    attitude)."""
    q = np.array(q, dtype=float)
    flip = np.cumprod(np.where(np.sum(q[1:] * q[:-1], axis=1) < 0.0, -1.0, 1.0))
    q[1:] *= flip[:, None]
    out = interpolate(t, q, at)
    return out / np.linalg.norm(out, axis=1, keepdims=True)
