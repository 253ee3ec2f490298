"""A dive's flight log as the identification reads it.

The log is the firmware's DataFlash file (``firmware/flightlog/``,
docs/design/flight-log.md), read with pymavlink's ``DFReader``. What the
fit needs of it:

- the input: WING, the commanded wing angles (5 Hz; the servos report no
  angle, so the command through the servo model is what is known);
- what the vehicle did: BARO (depth of the pressure port, 10 Hz), ATT
  (the estimator's roll, pitch, yaw, 25 Hz), IMU (body rates, 25 Hz), FIX
  (the tracker's positions, each with its age: measured ``Age`` ms before
  the record) and EST (the estimator's velocity, for the start of a
  segment);
- the attitude: ATT, the estimator's. Its accelerometer correction is
  pulled by the vehicle's own accelerations after the release (15 mrad of
  tilt on the twin), so ``shooting`` leaves its first ``RELEASE_TILT_S``
  out. (The IMU's rates integrated instead drift more: a 25 Hz record of
  a 10 ms mean misses the rocking of the release, 46 mrad in 1 s on the
  twin.) The gyro's bias is the mean rate while the vehicle was held still
  between arming and the release (a segment's starting rates);
- when the vehicle was let go: the first IMU record whose specific force
  is off gravity by more than ``RELEASE_G`` (held, the accelerometer reads
  g; let go, the vehicle falls at a good fraction of g);
- until when the water alone moved it: the depth stops ``BOTTOM_MARGIN_M``
  above the deepest the log reached, before a wing tip can touch;
- where the input is unknown: the ring thins or drops records when it
  fills (WING stops first), and a stretch with no WING record for longer
  than ``WING_GAP_S`` is not flown.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

#: m/s^2: a specific force this far from g means the vehicle is falling.
#: Held, the IMU record (a slot's mean) reads g within ~0.05 m/s^2 (the
#: twin's sensor noise); let go, the buildable vehicle's first records dip
#: 0.5-0.8 m/s^2 below g (its added mass is most of its inertia, and the
#: wings still folding at the release keep the dip small): 0.6 missed a
#: 0.57 one and took the landing's jolt for the release.
RELEASE_G = 0.3
#: m above the deepest logged depth where the fitted stretch ends.
BOTTOM_MARGIN_M = 0.3
#: s: WING records further apart than this leave the input unknown.
WING_GAP_S = 0.5
#: s before the release that may already be the hand letting go
HOLD_MARGIN_S = 0.1
#: IMU records of the vehicle held still needed for the gyro's bias
MIN_HOLD_RECORDS = 5
_G = 9.80665


class LogError(ValueError):
    """A log that cannot be identified from, said in one line."""


@dataclass
class DiveLog:
    """One dive: times in s since the board started, angles in rad, NED."""

    path: str
    t_release: float
    t_end: float
    baro_t: np.ndarray          #: (B,)
    depth: np.ndarray           #: (B,) m, the pressure port's depth
    att_t: np.ndarray           #: (A,)
    euler: np.ndarray           #: (A, 3) roll, pitch, yaw
    imu_t: np.ndarray           #: (I,)
    gyro: np.ndarray            #: (I, 3) rad/s, body axes
    wing_t: np.ndarray          #: (W,)
    wings: np.ndarray           #: (W, 4) commanded, rad
    fix_t: np.ndarray           #: (F,) measurement times
    fix_ne: np.ndarray          #: (F, 2) m
    est_t: np.ndarray           #: (E,)
    est_vel: np.ndarray         #: (E, 3) m/s NED
    params: dict = field(default_factory=dict)
    dropped: int = 0            #: records the ring dropped (PM's Drop)
    gyro_bias: Optional[np.ndarray] = None   #: rad/s, from the hold (removed from gyro)

    def wing_command(self, t: np.ndarray) -> np.ndarray:
        """Commanded wings (N, 4) at times t: linear between WING records
        (the firmware slews its commands, CTL_SLEW_DPS)."""
        return np.stack([np.interp(t, self.wing_t, self.wings[:, i]) for i in range(4)], axis=1)

    def input_known(self, t0: float, t1: float) -> bool:
        """WING records cover [t0, t1] with no gap longer than WING_GAP_S."""
        inside = self.wing_t[(self.wing_t >= t0) & (self.wing_t <= t1)]
        edges = np.concatenate(([t0], inside, [t1]))
        before = self.wing_t[self.wing_t <= t0]
        return len(before) > 0 and float(np.max(np.diff(edges))) <= WING_GAP_S

    def summary(self) -> dict:
        return {"file": self.path, "release_s": self.t_release, "end_s": self.t_end,
                "dive_s": self.t_end - self.t_release, "depth_m": [float(self.depth.min()), float(self.depth.max())],
                "fixes": int(np.count_nonzero((self.fix_t >= self.t_release) & (self.fix_t <= self.t_end))),
                "records_dropped": self.dropped}


def _rows(messages: dict, name: str, columns: tuple) -> np.ndarray:
    rows = messages.get(name, [])
    return np.array([[m.TimeUS * 1e-6] + [float(getattr(m, c)) for c in columns] for m in rows], float).reshape(
        -1, 1 + len(columns))


def read(path: str) -> DiveLog:
    """The dive in the log at ``path``. ``LogError`` says why not: no such
    file, not a DataFlash log, or no dive in it (never released, no
    depth, no wing commands)."""
    if not os.path.isfile(path):
        raise LogError("%s: no such log file" % path)
    with open(path, "rb") as f:
        head = f.read(3)
    if head[:2] != b"\xa3\x95":
        raise LogError("%s: not a DataFlash log (it does not start with a record header)" % path)
    from pymavlink import DFReader

    try:
        reader = DFReader.DFReader_binary(path)
        messages: dict = {}
        while True:
            m = reader.recv_msg()
            if m is None:
                break
            messages.setdefault(m.get_type(), []).append(m)
    except Exception as exc:   # noqa: BLE001 - pymavlink raises whatever a damaged file makes it raise
        raise LogError("%s: unreadable DataFlash log (%s: %s)" % (path, type(exc).__name__, exc))
    for need in ("BARO", "ATT", "IMU", "WING"):
        if not messages.get(need):
            raise LogError("%s: no %s records, nothing to identify from (LOG_BITMASK?)" % (path, need))
    baro = _rows(messages, "BARO", ("Alt",))
    att = _rows(messages, "ATT", ("Roll", "Pitch", "Yaw"))
    imu = _rows(messages, "IMU", ("GyrX", "GyrY", "GyrZ", "AccX", "AccY", "AccZ"))
    wing = _rows(messages, "WING", ("Cmd1", "Cmd2", "Cmd3", "Cmd4"))
    fix = _rows(messages, "FIX", ("N", "E", "Age"))
    est = _rows(messages, "EST", ("VN", "VE", "VD"))
    params = {m.Name: float(m.Value) for m in messages.get("PARM", [])}
    dropped = int(sum(float(getattr(m, "Drop", 0)) for m in messages.get("PM", [])))
    arm = [m.TimeUS * 1e-6 for m in messages.get("EV", []) if int(m.Id) == 10]   # ArduPilot's ARMED event
    t_arm = arm[0] if arm else float(imu[0, 0])
    acc = np.linalg.norm(imu[:, 4:7], axis=1)
    falling = np.nonzero((imu[:, 0] > t_arm) & (np.abs(acc - _G) > RELEASE_G))[0]
    if not len(falling):
        raise LogError("%s: the vehicle was never let go (the accelerometer reads g throughout)" % path)
    # the IMU record is the mean over the slot before it: the fall began
    # about half a record period earlier than the record that shows it
    period = float(np.median(np.diff(imu[:, 0])))
    t_release = float(imu[falling[0], 0] - 0.5 * period)
    depth = -baro[:, 1]
    after = baro[:, 0] >= t_release
    if np.count_nonzero(after) < 10:
        raise LogError("%s: fewer than 10 depth records after the release at %.2f s" % (path, t_release))
    deepest = float(depth[after].max())
    beyond = np.nonzero(after & (depth >= deepest - BOTTOM_MARGIN_M))[0]
    t_end = float(baro[beyond[0], 0])
    if t_end - t_release < 2.0:
        raise LogError("%s: the dive lasts %.1f s before the bottom, too short to fit" % (path, t_end - t_release))
    fix_t = fix[:, 0] - fix[:, 3] * 1e-3
    ok = np.isfinite(fix[:, 1]) & np.isfinite(fix[:, 2])
    euler = np.radians(att[:, 1:4])
    att_t = att[:, 0]
    held = (imu[:, 0] > t_arm) & (imu[:, 0] < t_release - HOLD_MARGIN_S)
    bias = imu[held, 1:4].mean(axis=0) if np.count_nonzero(held) >= MIN_HOLD_RECORDS else np.zeros(3)
    return DiveLog(path=path, t_release=t_release, t_end=t_end, baro_t=baro[:, 0], depth=depth,
                   att_t=att_t, euler=euler, imu_t=imu[:, 0], gyro=imu[:, 1:4] - bias,
                   wing_t=wing[:, 0], wings=np.radians(wing[:, 1:5]), fix_t=fix_t[ok], fix_ne=fix[ok, 1:3],
                   est_t=est[:, 0], est_vel=est[:, 1:4], params=params, dropped=dropped, gyro_bias=bias)


def slew_limit(params: dict) -> float:
    """rad/s: how fast the firmware may move a wing command (CTL_SLEW_DPS)."""
    return math.radians(params.get("CTL_SLEW_DPS", 60.0))


def euler_to_quaternion(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Body -> NED quaternion [w, x, y, z] of ZYX Euler angles (ATT's)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


def unwrap_interp(t: np.ndarray, tp: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """An angle (rad) at times t, interpolated on the circle."""
    return np.interp(t, tp, np.unwrap(angle))
