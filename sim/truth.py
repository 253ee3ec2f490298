"""What really happened in a simulated run: the input of every sensor model.

The dynamics model fills a ``Truth`` (``roboray.sim.dynamics``); sensor
models (``roboray.sim.sensors``) turn it into what the IMU, the depth sensor
and the position tracker report; estimators are scored against it.

Frames and units: NED inertial frame, body frame ``x_c, y_c`` in the centre
plate (wing 1 on +x_c, wing 2 on +y_c), ``z_c`` along the symmetry axis,
down when the vehicle descends level; SI units, radians.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

GRAVITY_NED = np.array([0.0, 0.0, 9.80665])


@dataclass(frozen=True)
class Truth:
    """A trajectory sampled at times ``t``; every array's first axis is time."""

    t: np.ndarray                   #: (N,) s
    position_ned: np.ndarray        #: (N, 3) m, of the reference point (the dynamics: plate centre O, or a point given)
    velocity_ned: np.ndarray        #: (N, 3) m/s, of the reference point, over ground (current included)
    quaternion: np.ndarray          #: (N, 4) [w, x, y, z], body -> NED
    omega_body: np.ndarray          #: (N, 3) rad/s, body rates
    specific_force_imu: np.ndarray  #: (N, 3) m/s^2, body frame, at the IMU: a_imu - g
    depth_sensor: np.ndarray        #: (N,) m, depth of the pressure port
    wings: np.ndarray               #: (N, 4) rad, wing deflections s_1..s_4
    wing_rates: np.ndarray          #: (N, 4) rad/s
    imu_position_body: np.ndarray = field(default_factory=lambda: np.zeros(3))  #: (3,) m from the reference point
    water_velocity_ned: np.ndarray | None = None  #: (N, 3) m/s current at the vehicle, None = still water
    port_position_body: np.ndarray | None = None  #: (3,) m, pressure port from the reference point

    def __post_init__(self) -> None:
        n = len(self.t)
        shapes = {
            "position_ned": (n, 3), "velocity_ned": (n, 3), "quaternion": (n, 4),
            "omega_body": (n, 3), "specific_force_imu": (n, 3), "depth_sensor": (n,),
            "wings": (n, 4), "wing_rates": (n, 4),
        }
        for name, shape in shapes.items():
            got = np.shape(getattr(self, name))
            if got != shape:
                raise ValueError("Truth.%s has shape %s, expected %s" % (name, got, shape))
        if self.water_velocity_ned is not None and np.shape(self.water_velocity_ned) != (n, 3):
            raise ValueError("Truth.water_velocity_ned has shape %s, expected %s"
                             % (np.shape(self.water_velocity_ned), (n, 3)))

    def __len__(self) -> int:
        return len(self.t)

    def rotation(self) -> np.ndarray:
        """(N, 3, 3) body -> NED rotation matrices."""
        return quaternion_to_matrix(self.quaternion)


def quaternion_to_matrix(q: np.ndarray) -> np.ndarray:
    """[w, x, y, z] (..., 4) -> rotation matrices (..., 3, 3), body -> NED."""
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    r = np.empty(q.shape[:-1] + (3, 3))
    r[..., 0, 0] = 1 - 2 * (y * y + z * z)
    r[..., 0, 1] = 2 * (x * y - w * z)
    r[..., 0, 2] = 2 * (x * z + w * y)
    r[..., 1, 0] = 2 * (x * y + w * z)
    r[..., 1, 1] = 1 - 2 * (x * x + z * z)
    r[..., 1, 2] = 2 * (y * z - w * x)
    r[..., 2, 0] = 2 * (x * z - w * y)
    r[..., 2, 1] = 2 * (y * z + w * x)
    r[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return r
