"""Unit quaternions for attitude, allocation-free.

Convention: ``q = [w, x, y, z]`` (scalar first) rotates a vector from the
body frame (x forward along wing 1, z along the symmetry axis, down when
level) to the NED frame: ``v_ned = q * v_body * q^-1``. Every function
writes into an ``array('f')`` the caller made once, so a filter step builds
no list or tuple; only the float temporaries are boxed.
"""

import math


def set_identity(q):
    q[0] = 1.0
    q[1] = 0.0
    q[2] = 0.0
    q[3] = 0.0


def mul(out, a, b):
    """out = a * b (Hamilton product). ``out`` must not be ``a`` or ``b``."""
    aw = a[0]
    ax = a[1]
    ay = a[2]
    az = a[3]
    bw = b[0]
    bx = b[1]
    by = b[2]
    bz = b[3]
    out[0] = aw * bw - ax * bx - ay * by - az * bz
    out[1] = aw * bx + ax * bw + ay * bz - az * by
    out[2] = aw * by - ax * bz + ay * bw + az * bx
    out[3] = aw * bz + ax * by - ay * bx + az * bw


def normalize(q):
    """Scale ``q`` to unit norm in place; a zero quaternion becomes identity."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if n < 1e-12:
        set_identity(q)
        return
    inv = 1.0 / n
    q[0] *= inv
    q[1] *= inv
    q[2] *= inv
    q[3] *= inv


def rotate(out, q, v):
    """out = R(q) v: a body vector expressed in NED."""
    _rotate(out, q[0], q[1], q[2], q[3], v)


def rotate_inverse(out, q, v):
    """out = R(q)^T v: an NED vector expressed in the body frame."""
    _rotate(out, q[0], -q[1], -q[2], -q[3], v)


def _rotate(out, w, x, y, z, v):
    vx = v[0]
    vy = v[1]
    vz = v[2]
    # v + 2 w (u x v) + 2 u x (u x v), with u = (x, y, z) the vector part
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    out[0] = vx + w * tx + y * tz - z * ty
    out[1] = vy + w * ty + z * tx - x * tz
    out[2] = vz + w * tz + x * ty - y * tx


def integrate(q, wx, wy, wz, dt):
    """Advance ``q`` by the body rate (rad/s) over ``dt`` s, exactly for a
    constant rate (exponential map), then renormalise."""
    half = 0.5 * dt
    ax = wx * half
    ay = wy * half
    az = wz * half
    angle = math.sqrt(ax * ax + ay * ay + az * az)
    if angle < 1e-6:
        c = 1.0
        s = 1.0  # sin(angle)/angle to first order
    else:
        c = math.cos(angle)
        s = math.sin(angle) / angle
    ax *= s
    ay *= s
    az *= s
    w = q[0]
    x = q[1]
    y = q[2]
    z = q[3]
    q[0] = c * w - ax * x - ay * y - az * z
    q[1] = c * x + ax * w + az * y - ay * z
    q[2] = c * y + ay * w - az * x + ax * z
    q[3] = c * z + az * w + ay * x - ax * y
    normalize(q)


def turn(q, hx, hy, hz):
    """q <- q * (1, hx, hy, hz): a small body rotation of (2 hx, 2 hy, 2 hz)
    rad, to first order, without renormalising (the caller decides when)."""
    w = q[0]
    x = q[1]
    y = q[2]
    z = q[3]
    q[0] = w - hx * x - hy * y - hz * z
    q[1] = x + hx * w + hz * y - hy * z
    q[2] = y + hy * w - hz * x + hx * z
    q[3] = z + hz * w + hy * x - hx * y


def from_euler(q, roll, pitch, yaw):
    """Z-Y-X (yaw, pitch, roll) Euler angles in radians to ``q``."""
    cr = math.cos(0.5 * roll)
    sr = math.sin(0.5 * roll)
    cp = math.cos(0.5 * pitch)
    sp = math.sin(0.5 * pitch)
    cy = math.cos(0.5 * yaw)
    sy = math.sin(0.5 * yaw)
    q[0] = cr * cp * cy + sr * sp * sy
    q[1] = sr * cp * cy - cr * sp * sy
    q[2] = cr * sp * cy + sr * cp * sy
    q[3] = cr * cp * sy - sr * sp * cy


def to_euler(out, q):
    """``q`` to [roll, pitch, yaw] in radians (Z-Y-X), written into ``out``."""
    w = q[0]
    x = q[1]
    y = q[2]
    z = q[3]
    out[0] = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    s = 2.0 * (w * y - z * x)
    if s > 1.0:
        s = 1.0
    elif s < -1.0:
        s = -1.0
    out[1] = math.asin(s)
    out[2] = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def tilt(q):
    """Angle in radians between the body z axis and NED down."""
    x = q[1]
    y = q[2]
    c = 1.0 - 2.0 * (x * x + y * y)  # (R e_z) . e_z
    if c > 1.0:
        c = 1.0
    elif c < -1.0:
        c = -1.0
    return math.acos(c)


def to_matrix(R, q):
    """R (9, row major) = the rotation of unit q, body -> NED: 24 boxed floats."""
    w = q[0]
    x = q[1]
    y = q[2]
    z = q[3]
    x2 = x + x
    y2 = y + y
    z2 = z + z
    xx = x * x2
    yy = y * y2
    zz = z * z2
    xy = x * y2
    xz = x * z2
    yz = y * z2
    wx = w * x2
    wy = w * y2
    wz = w * z2
    R[0] = 1.0 - (yy + zz)
    R[1] = xy - wz
    R[2] = xz + wy
    R[3] = xy + wz
    R[4] = 1.0 - (xx + zz)
    R[5] = yz - wx
    R[6] = xz - wy
    R[7] = yz + wx
    R[8] = 1.0 - (xx + yy)
