"""quaternions.py: scipy's Rotation conversions without importing scipy.spatial, every axis order,
at gimbal lock, and at tiny angles."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest

from headmotion import quaternions as Q

Rotation = pytest.importorskip("scipy.spatial.transform").Rotation
ORDERS = ["".join(p) for p in itertools.product("xyz", repeat=3) if p[0] != p[1] and p[1] != p[2]]
ORDERS += [o.upper() for o in ORDERS]


def _rotvecs():
    rng = np.random.default_rng(0)
    rv = np.concatenate([0.3 * rng.standard_normal((500, 3)), 1.5 * rng.standard_normal((500, 3)),
                         1e-5 * rng.standard_normal((20, 3)), np.zeros((2, 3))])
    return rv / np.maximum(1.0, np.linalg.norm(rv, axis=1, keepdims=True) / 3.1)   # angles up to 3.1 rad


def _angle_diff(a, b):
    d = np.abs(a - b)
    return np.minimum(d, 2 * np.pi - d)


def test_rotvec_quaternion_round_trip_equals_scipy():
    rv = _rotvecs()
    np.testing.assert_allclose(Q.rotvec_to_quat(rv), Rotation.from_rotvec(rv).as_quat(), atol=1e-15)
    np.testing.assert_allclose(Q.quat_to_rotvec(Rotation.from_rotvec(rv).as_quat()), rv, atol=1e-14)
    # a known answer: 90° about z
    np.testing.assert_allclose(Q.rotvec_to_quat([[0, 0, np.pi / 2]]), [[0, 0, np.sqrt(0.5), np.sqrt(0.5)]], atol=1e-15)


@pytest.mark.parametrize("order", ORDERS)
def test_euler_conversions_equal_scipy(order):
    rv = _rotvecs()
    e = Rotation.from_rotvec(rv).as_euler(order)
    assert _angle_diff(Q.rotvec_to_euler(rv, order), e).max() < 1e-12
    np.testing.assert_allclose(Q.euler_to_rotvec(e, order), Rotation.from_euler(order, e).as_rotvec(), atol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # scipy warns at gimbal lock
        for a0, a2 in ((0.3, 0.2), (-1.1, 0.5), (2.0, -2.5)):
            for mid in ((np.pi / 2, -np.pi / 2) if order[0].lower() != order[2].lower() else (0.0, np.pi)):
                q = Rotation.from_euler(order, [[a0, mid, a2]]).as_quat()
                assert _angle_diff(Q.quat_to_euler(q, order), Rotation.from_quat(q).as_euler(order)).max() < 1e-12


def test_bad_order_is_an_error():
    with pytest.raises(ValueError, match="Euler order"):
        Q.rotvec_to_euler(np.zeros((1, 3)), "xYz")


def test_the_heads_own_order_written_out_gives_the_general_steps_bits():
    """``"YXZ"`` (yaw, pitch, roll) goes through its written-out functions, which must give the
    bits of the general steps, including at gimbal lock, tiny angles and angles that wrap."""
    rv = _rotvecs()
    np.testing.assert_array_equal(Q.rotvec_to_yxz(rv), Q.quat_to_euler(Q.rotvec_to_quat(rv), "YXZ"))
    rng = np.random.default_rng(1)
    angles = np.concatenate([rng.uniform(-3.0, 3.0, (2000, 3)), 1e-5 * rng.standard_normal((20, 3)),
                             [[0.3, np.pi / 2, 0.2], [0.3, -np.pi / 2, 0.2], [0.1, np.pi / 2 - 1e-8, 0.4],
                              [0.0, 0.0, 0.0], [3.1, 0.2, -3.1]]])
    general = Q.quat_to_rotvec(Q.euler_to_quat("YXZ", angles))
    np.testing.assert_array_equal(Q.yxz_to_rotvec(angles), general)
    np.testing.assert_array_equal(Q.euler_to_rotvec(angles, "YXZ"), general)
    for k in (0, 1, 2, len(angles) - 1):  # one frame at a time, as a stream converts them
        np.testing.assert_array_equal(Q.yxz_to_rotvec(angles[k:k + 1]), general[k:k + 1])
        np.testing.assert_array_equal(Q.rotvec_to_yxz(general[k:k + 1]),
                                      Q.quat_to_euler(Q.rotvec_to_quat(general[k:k + 1]), "YXZ"))
