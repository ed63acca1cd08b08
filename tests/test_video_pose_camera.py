"""Video pose, camera model: a face seen through a pinhole camera that moves
across the image without turning reads as still after the line-of-sight correction, and known
rotations of a moving face are recovered under perspective."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion.video.pose import CAMERA_TO_HEAD, estimate_pose, line_of_sight
from test_video_pose import face_shape, rel_err_deg

W = H = 512
F = float(np.hypot(W, H))


def pinhole(ref, rotvec, pos_cm, *, size_cm=8.0, f=F):
    """FaceMesh-like landmarks of a rigid face (head axes) turned by ``rotvec`` and placed at
    ``pos_cm (T, 3)`` (camera axes, z = distance) by a pinhole camera: x, y the true perspective
    projection in pixels; z the depth along the line of sight relative to the face centre, on the
    scale of x (FaceMesh predicts depth from a crop around the face, i.e. along that ray)."""
    R = Rotation.from_rotvec(rotvec).as_matrix()
    X = size_cm * np.einsum("tij,nj->tni", R, ref) * CAMERA_TO_HEAD + pos_cm[:, None]  # camera axes, cm
    u = f * X[..., 0] / X[..., 2] + W / 2
    v = f * X[..., 1] / X[..., 2] + H / 2
    dist = np.linalg.norm(pos_cm, axis=1)
    ray = pos_cm / dist[:, None]
    z = f * np.einsum("tni,ti->tn", X - pos_cm[:, None], ray) / dist[:, None]
    return np.stack([u, v, z], -1)


def test_line_of_sight_of_the_image_centre_is_identity():
    R = line_of_sight(np.array([[W / 2, H / 2]]), width=W, height=H)
    np.testing.assert_allclose(R[0], np.eye(3), atol=1e-12)
    # a face to the right of the image (the speaker's left) is seen along a ray turned towards +x:
    # the optical axis (head −z) turned about y
    R = line_of_sight(np.array([[W / 2 + F * np.tan(0.1), H / 2]]), width=W, height=H)
    assert Rotation.from_matrix(R).magnitude()[0] == pytest.approx(0.1)


def test_face_moving_without_turning_reads_as_still(rng):
    ref = face_shape(rng)
    ref = ref - ref.mean(0)  # turn about the landmarks' centre
    T = 200
    t = np.arange(T) / 25.0
    # the head slides 12 cm sideways and 6 cm up and down at 60 cm, never turning
    pos = np.stack([12 * np.sin(2 * np.pi * 0.2 * t), 6 * np.sin(2 * np.pi * 0.3 * t), np.full(T, 60.0)], 1)
    pts = pinhole(ref, np.zeros((T, 3)), pos)
    plain = estimate_pose(pts, line_of_sight_correction=False, width=W, height=H).rotvec
    fixed = estimate_pose(pts, width=W, height=H).rotvec
    # uncorrected, the slide reads as several degrees of yaw and pitch
    assert np.degrees(np.ptp(plain[:, 1])) > 15 and np.degrees(np.ptp(plain[:, 0])) > 8
    # corrected, what is left (< 1.5° peak to peak, a twentieth) is the perspective distortion
    # of a 16 cm face at 60 cm, which no rigid fit removes
    assert np.all(np.degrees(np.ptp(fixed, 0)) < 1.5)
    assert np.all(np.ptp(fixed, 0)[:2] < 0.1 * np.ptp(plain, 0)[:2])


def test_known_rotations_with_translation_under_perspective(rng):
    ref = face_shape(rng)
    ref = ref - ref.mean(0)
    T = 300
    true = np.radians(rng.uniform(-15, 15, (T, 3)))
    pos = np.stack([rng.uniform(-8, 8, T), rng.uniform(-5, 5, T), rng.uniform(55, 65, T)], 1)
    pts = pinhole(ref, true, pos) + rng.normal(0, 0.5, (T, len(ref), 3))
    err_fixed = rel_err_deg(estimate_pose(pts, width=W, height=H).rotvec, true)
    err_plain = rel_err_deg(estimate_pose(pts, width=W, height=H, line_of_sight_correction=False).rotvec, true)
    assert np.median(err_fixed) < 1.0 and np.median(err_plain) > 2 * np.median(err_fixed)
