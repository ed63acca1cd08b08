"""Rotation-vector ↔ Euler-angle conversions in numpy, without importing ``scipy.spatial``.

``import scipy.spatial.transform`` also imports scipy.sparse, scipy.linalg and the k-d tree
(~0.15–0.25 s, more than the rest of ``headmotion stream``'s start), while head motion needs only
a handful of conversions per frame.  These are the steps of :class:`scipy.spatial.transform.Rotation`
(quaternions ``(x, y, z, w)``; scipy's series below 1e-3 rad; Euler angles from a quaternion by
Bernardes & Viollet 2022, "Quaternion to Euler angles conversion: a direct, general and
computationally efficient method", PLoS ONE 17(11), as scipy computes them), vectorised over
frames; they agree with scipy to ~1e-15 rad (``tests/test_quaternions.py``, every axis order).
At gimbal lock (middle angle within 1e-7 rad of its limit) the third angle is set to zero, as
scipy does (scipy also warns).
"""

from __future__ import annotations

import numpy as np

_AXIS = {"x": 0, "y": 1, "z": 2}


def rotvec_to_quat(rotvec: np.ndarray) -> np.ndarray:
    """``(T, 3)`` rotation vectors → ``(T, 4)`` unit quaternions ``(x, y, z, w)``."""
    r = np.asarray(rotvec, dtype=np.float64).reshape(-1, 3)
    angle = np.sqrt(np.add.reduce(r * r, axis=1))  # np.linalg.norm(r, axis=1), without its call overhead
    small = angle <= 1e-3
    with np.errstate(invalid="ignore", divide="ignore"):
        if small.any():  # (the series only where needed: a live head converts a frame or two at a time)
            a2 = angle * angle
            scale = np.where(small, 0.5 - a2 / 48.0 + a2 * a2 / 3840.0,
                             np.sin(0.5 * angle) / np.where(small, 1.0, angle))
        else:
            scale = np.sin(0.5 * angle) / angle
    return np.column_stack([scale[:, None] * r, np.cos(0.5 * angle)])


def quat_to_rotvec(quat: np.ndarray) -> np.ndarray:
    """``(T, 4)`` quaternions ``(x, y, z, w)`` → ``(T, 3)`` rotation vectors (angle in [0, π])."""
    q = np.asarray(quat, dtype=np.float64).reshape(-1, 4)
    neg = q[:, 3] < 0
    if neg.any():
        q = np.where(neg[:, None], -q, q)
    v = q[:, :3]
    angle = 2.0 * np.arctan2(np.sqrt(np.add.reduce(v * v, axis=1)), q[:, 3])
    small = angle <= 1e-3
    if small.any():
        a2 = angle * angle
        scale = np.where(small, 2.0 + a2 / 12.0 + 7.0 * a2 * a2 / 2880.0,
                         angle / np.sin(0.5 * np.where(small, 1.0, angle)))
    else:
        scale = angle / np.sin(0.5 * angle)
    return scale[:, None] * v


def compose(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Quaternion product ``p ⊗ q`` (rotation ``q`` first, then ``p``), ``(T, 4)`` each."""
    pv, pw, qv, qw = p[:, :3], p[:, 3:], q[:, :3], q[:, 3:]
    (a0, a1, a2), (b0, b1, b2) = pv.T, qv.T  # the cross product as np.cross computes it, without its
    cross = np.column_stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])  # per-call overhead
    return np.column_stack([pw * qv + qw * pv + cross, pw * qw - np.sum(pv * qv, axis=1, keepdims=True)])


def _check(order: str) -> tuple[str, bool]:
    if not (isinstance(order, str) and len(order) == 3 and set(order.lower()) <= set("xyz")
            and (order.isupper() or order.islower())):
        raise ValueError(f"Euler order must be three of x/y/z, all upper case (intrinsic) or all lower case "
                         f"(extrinsic); got {order!r}")
    return order.lower(), order.islower()


def euler_to_quat(order: str, angles: np.ndarray) -> np.ndarray:
    """Euler ``angles`` ``(T, 3)`` (radians) about the axes of ``order`` → quaternions ``(T, 4)``."""
    seq, extrinsic = _check(order)
    a = np.asarray(angles, dtype=np.float64).reshape(-1, 3)

    def elementary(axis: str, angle: np.ndarray) -> np.ndarray:
        q = np.zeros((len(angle), 4))
        q[:, 3] = np.cos(0.5 * angle)
        q[:, _AXIS[axis]] = np.sin(0.5 * angle)
        return q

    out = elementary(seq[0], a[:, 0])
    for i in (1, 2):
        e = elementary(seq[i], a[:, i])
        out = compose(e, out) if extrinsic else compose(out, e)
    return out


def quat_to_euler(quat: np.ndarray, order: str) -> np.ndarray:
    """Quaternions ``(T, 4)`` → Euler angles ``(T, 3)`` about the axes of ``order`` (radians;
    the first and last in [−π, π], the middle in [−π/2, π/2] or [0, π] for repeated axes)."""
    seq, extrinsic = _check(order)
    q = np.asarray(quat, dtype=np.float64).reshape(-1, 4)
    if not extrinsic:
        seq = seq[::-1]
    i, j, k = (_AXIS[c] for c in seq)
    symmetric = i == k
    if symmetric:
        k = 3 - i - j
    sign = (i - j) * (j - k) * (k - i) // 2
    if symmetric:
        a, b, c, d = q[:, 3], q[:, i], q[:, j], q[:, k] * sign
    else:
        a, b, c, d = q[:, 3] - q[:, j], q[:, i] + q[:, k] * sign, q[:, j] + q[:, 3], q[:, k] * sign - q[:, i]
    mid = 2.0 * np.arctan2(np.hypot(c, d), np.hypot(a, b))
    half_sum, half_diff = np.arctan2(b, a), np.arctan2(d, c)
    eps = 1e-7
    lock0 = np.abs(mid) <= eps
    lockpi = np.abs(mid - np.pi) <= eps
    # gimbal lock: the angle that comes last in the order given is set to zero (the first of the
    # reversed computation for an intrinsic order)
    locked = np.where(lock0, 2.0 * half_sum, 2.0 * half_diff * (-1.0 if extrinsic else 1.0))
    lock = lock0 | lockpi
    if extrinsic:
        first = np.where(lock, locked, half_sum - half_diff)
        third = np.where(lock, 0.0, half_sum + half_diff)
    else:
        first = np.where(lock, 0.0, half_sum - half_diff)
        third = np.where(lock, locked, half_sum + half_diff)
    if not symmetric:
        third = third * sign
        mid = mid - np.pi / 2
    if not extrinsic:
        first, third = third, first
    out = np.column_stack([first, mid, third])
    out = np.where(out < -np.pi, out + 2 * np.pi, out)
    return np.where(out > np.pi, out - 2 * np.pi, out)


def rotvec_to_euler(rotvec: np.ndarray, order: str) -> np.ndarray:
    """Rotation vectors ``(T, 3)`` → Euler angles ``(T, 3)`` (radians) in ``order``."""
    if order == "YXZ":
        return rotvec_to_yxz(rotvec)
    return quat_to_euler(rotvec_to_quat(rotvec), order)


def euler_to_rotvec(angles: np.ndarray, order: str) -> np.ndarray:
    """Euler angles ``(T, 3)`` (radians) in ``order`` → rotation vectors ``(T, 3)``."""
    if order == "YXZ":
        return yxz_to_rotvec(angles)
    return quat_to_rotvec(euler_to_quat(order, angles))


# The head's own order, intrinsic "YXZ" (yaw, pitch, roll: headmotion.rotations), is converted for
# every frame a live head sends, one or two frames at a time; the general Euler steps above cost
# 100–220 µs a call there, mostly numpy's per-call overhead on tiny arrays.  The two functions below
# write the Euler steps out for this order: the same operations on the same values in the same
# order (the products with the elementary quaternions' zeros, which add or subtract exact zeros,
# left out), so the same bits, at a third to a half of the cost (``tests/test_quaternions.py``).

def yxz_to_rotvec(angles: np.ndarray) -> np.ndarray:
    """Intrinsic ``"YXZ"`` angles ``(T, 3)`` (yaw, pitch, roll; radians) → rotation vectors:
    :func:`euler_to_quat`, written out for this order, then :func:`quat_to_rotvec`."""
    a = np.asarray(angles, dtype=np.float64).reshape(-1, 3)
    h = 0.5 * a
    s, c = np.sin(h), np.cos(h)
    sy, sx, sz, cy, cx, cz = s[:, 0], s[:, 1], s[:, 2], c[:, 0], c[:, 1], c[:, 2]
    # q_y(yaw) ⊗ q_x(pitch), then ⊗ q_z(roll), as compose() computes them
    x1, y1, z1, w1 = cy * sx, cx * sy, -(sy * sx), cy * cx
    q = np.empty((len(a), 4))
    q[:, 0] = cz * x1 + y1 * sz
    q[:, 1] = cz * y1 - x1 * sz
    q[:, 2] = w1 * sz + cz * z1
    q[:, 3] = w1 * cz - z1 * sz
    return quat_to_rotvec(q)


def rotvec_to_yxz(rotvec: np.ndarray) -> np.ndarray:
    """Rotation vectors ``(T, 3)`` → intrinsic ``"YXZ"`` angles ``(T, 3)`` (yaw, pitch, roll;
    radians): :func:`rotvec_to_quat` then :func:`quat_to_euler`, the latter written out for this
    order."""
    q = rotvec_to_quat(rotvec)
    qx, qy, qz, qw = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    # quat_to_euler for "YXZ": the reversed sequence z, x, y (i, j, k), sign +1
    a, b, c, d = qw - qx, qz + qy, qx + qw, qy - qz
    mid = 2.0 * np.arctan2(np.hypot(c, d), np.hypot(a, b))
    half_sum, half_diff = np.arctan2(b, a), np.arctan2(d, c)
    eps = 1e-7
    lock0 = np.abs(mid) <= eps
    lockpi = np.abs(mid - np.pi) <= eps
    lock = lock0 | lockpi
    out = np.empty((len(q), 3))
    if lock.any():
        locked = np.where(lock0, 2.0 * half_sum, 2.0 * half_diff)
        out[:, 0] = np.where(lock, locked, half_sum + half_diff)
        out[:, 2] = np.where(lock, 0.0, half_sum - half_diff)
    else:
        out[:, 0] = half_sum + half_diff
        out[:, 2] = half_sum - half_diff
    out[:, 1] = mid - np.pi / 2
    if (np.abs(out) > np.pi).any():
        out = np.where(out < -np.pi, out + 2 * np.pi, out)
        out = np.where(out > np.pi, out - 2 * np.pi, out)
    return out


__all__ = ["rotvec_to_quat", "quat_to_rotvec", "compose", "euler_to_quat", "quat_to_euler", "rotvec_to_euler",
           "euler_to_rotvec", "yxz_to_rotvec", "rotvec_to_yxz"]
