"""Core types, rotations and alignment: known answers (thesis §2.2.3)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion import Audio, FeatureTrack, Motion
from headmotion import rotations as rot
from headmotion.align import align_tracks, n_frames
from headmotion.errors import LengthMismatchError, ParameterError


def test_audio_validates_and_is_readonly():
    a = Audio(np.zeros(1600), 16000)
    assert a.samples.dtype == np.float32 and a.duration == pytest.approx(0.1)
    with pytest.raises(ValueError):
        a.samples[0] = 1.0
    with pytest.raises(ParameterError, match="not finite"):
        Audio(np.array([0.0, np.nan]), 16000)
    with pytest.raises(ParameterError, match="one-dimensional"):
        Audio(np.zeros((10, 2)), 16000)
    with pytest.raises(ParameterError, match="sample_rate"):
        Audio(np.zeros(10), 0)


def test_motion_validates_shape_and_nan():
    with pytest.raises(ParameterError, match=r"\(T, 3\)"):
        Motion(np.zeros((5, 2)), 100)
    with pytest.raises(ParameterError, match="NaN"):
        Motion(np.array([[0, 0, np.nan]]), 100)
    m = Motion(np.array([[0, 0, np.nan]]), 100, allow_nan=True)
    assert np.isnan(m.rotvec[0, 2])
    with pytest.raises(ParameterError, match="fps"):
        Motion(np.zeros((5, 3)), -1)


def test_featuretrack_names_must_match():
    with pytest.raises(ParameterError, match="names"):
        FeatureTrack(np.zeros((4, 2)), 100, ("a",))
    ft = FeatureTrack(np.arange(8).reshape(4, 2), 100, ("a", "b"))
    assert ft.select(["b"]).values[:, 0].tolist() == [1, 3, 5, 7]


@pytest.mark.parametrize("axis,name", [(0, "pitch"), (1, "yaw"), (2, "roll")])
def test_axis_convention_directions(axis, name):
    """The documented meaning of each positive rotation (rotations.py docstring)."""
    r = np.zeros(3)
    r[axis] = np.radians(20)
    m = rot.rotvec_to_matrix(r)[0]
    nose = m @ np.array([0, 0, 1.0])   # forward
    top = m @ np.array([0, 1.0, 0])    # up
    if name == "pitch":
        assert nose[1] < -0.3  # nose goes down
    elif name == "yaw":
        assert nose[0] > 0.3   # nose to the speaker's left (+x)
    else:
        assert top[0] < -0.3   # top of head to the speaker's right (-x)


def test_conversions_round_trip(rng):
    rv = rng.normal(scale=0.4, size=(50, 3))
    np.testing.assert_allclose(rot.matrix_to_rotvec(rot.rotvec_to_matrix(rv)), rv, atol=1e-10)
    np.testing.assert_allclose(rot.quat_to_rotvec(rot.rotvec_to_quat(rv)), rv, atol=1e-10)
    for order in ("XYZ", "YXZ", "ZXY", "zyx"):
        e = rot.rotvec_to_euler(rv, order)
        np.testing.assert_allclose(rot.euler_to_rotvec(e, order), rv, atol=1e-10)
    pyr = rot.rotvec_to_pitch_yaw_roll(rv)
    np.testing.assert_allclose(rot.pitch_yaw_roll_to_rotvec(pyr[:, 0], pyr[:, 1], pyr[:, 2]), rv, atol=1e-10)


def test_euler_order_is_explicit_and_checked():
    with pytest.raises(ParameterError, match="Euler order"):
        rot.rotvec_to_euler(np.zeros(3), "XY")
    with pytest.raises(ParameterError, match="Euler order"):
        rot.rotvec_to_euler(np.zeros(3), "XyZ")
    # order matters: the same angles in two orders are different rotations
    a = np.radians([[30, 20, 10]])
    assert not np.allclose(rot.euler_to_rotvec(a, "XYZ"), rot.euler_to_rotvec(a, "ZYX"))


def test_rotation_matrix_matches_thesis_eq_2_15():
    """Eq 2.15–2.18 (the Rodrigues form) against scipy for a non-trivial vector."""
    r = np.array([0.3, -0.2, 0.5])
    a = np.linalg.norm(r)
    s, c = np.sin(a / 2), np.cos(a / 2)
    rx, ry, rz = r
    v1 = np.array([(rx**2 - ry**2 - rz**2) * s**2 + a**2 * c**2, 2 * s * (rx * ry * s + a * rz * c),
                   2 * s * (rx * rz * s - a * ry * c)]) / a**2
    np.testing.assert_allclose(rot.rotvec_to_matrix(r)[0][:, 0], v1, atol=1e-12)


def test_relative_and_kabsch(rng):
    parent = rng.normal(scale=0.3, size=(10, 3))
    child = rng.normal(scale=0.3, size=(10, 3))
    rel = rot.relative_rotvec(parent, child)
    recomposed = (Rotation.from_rotvec(parent) * Rotation.from_rotvec(rel)).as_rotvec()
    np.testing.assert_allclose(recomposed, child, atol=1e-10)
    pts = rng.normal(size=(6, 3))
    true_r = Rotation.from_rotvec([0.2, -0.4, 0.1]).as_matrix()
    moved = pts @ true_r.T + np.array([1.0, 2.0, 3.0])
    r_est, t_est = rot.kabsch(pts, moved)
    np.testing.assert_allclose(r_est, true_r, atol=1e-10)
    np.testing.assert_allclose(t_est, [1, 2, 3], atol=1e-10)


def test_unwrap_removes_2pi_jumps():
    axis = np.array([0, 1.0, 0])
    angles = np.array([3.0, 3.1, 3.2 - 2 * np.pi, 3.3 - 2 * np.pi])  # wrapped representation
    rv = angles[:, None] * axis
    rv[2:] = (2 * np.pi + angles[2:])[:, None] * axis  # write the same rotations with angle > pi
    rv2 = Rotation.from_rotvec(rv).as_rotvec()  # scipy wraps to [0, pi]
    un = rot.unwrap_rotvec(rv2)
    assert np.max(np.linalg.norm(np.diff(un, axis=0), axis=1)) < 0.2


def test_motion_resample_keeps_duration():
    t = np.arange(100) / 100
    m = Motion(np.stack([0.1 * np.sin(2 * np.pi * t), np.zeros(100), np.zeros(100)], 1), 100)
    m25 = m.resample(25)
    assert len(m25) == 25 and m25.fps == 25
    np.testing.assert_allclose(m25.rotvec[:, 0], 0.1 * np.sin(2 * np.pi * np.arange(25) / 25), atol=1e-3)


@pytest.mark.parametrize("n_samples,sr,fps,expected", [
    (16000, 16000, 100, 100), (16001, 16000, 100, 100), (16079, 16000, 100, 100), (16080, 16000, 100, 101),
    (16000, 16000, 25, 25), (16000, 16000, 29.97, 30), (44100 * 3, 44100, 30, 90), (0, 16000, 100, 0),
])
def test_n_frames(n_samples, sr, fps, expected):
    assert n_frames(n_samples, sr, fps) == expected


def test_align_trims_within_tolerance_and_raises_beyond():
    audio = Audio(np.zeros(16000 + 300), 16000)   # 1.019 s
    motion = Motion(np.zeros((100, 3)), 100)      # 1.000 s
    a, m = align_tracks(audio, motion)
    assert len(m) == 100 and len(a) == 16000
    long_audio = Audio(np.zeros(16000 + 2000), 16000)  # 125 ms longer: beyond 10 ms + 50 ms
    with pytest.raises(LengthMismatchError, match=r"18000 samples.*100 frames"):
        align_tracks(long_audio, motion)
    ft = FeatureTrack(np.zeros((101, 2)), 100, ("a", "b"))
    m2, f2 = align_tracks(motion, ft)
    assert len(m2) == len(f2) == 100
