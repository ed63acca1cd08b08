"""Video → head pose: pose maths, axis convention, cuts, gaps, low-pass (no real data needed)."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion.errors import FormatError, MissingDependencyError
from headmotion.video import quality as q
from headmotion.video.pose import RIGID_LANDMARKS, batch_kabsch, estimate_pose, project


def face_shape(rng=None) -> np.ndarray:
    """A rigid face-like point set in head axes (x speaker's left, y up, z out of the nose)."""
    rng = np.random.default_rng(0) if rng is None else rng
    n = len(RIGID_LANDMARKS)
    # points on an ellipsoidal cap (forehead, cheeks) plus a nose ridge sticking out (+z)
    u = rng.uniform(-1.0, 1.0, n)
    v = rng.uniform(-1.0, 1.0, n)
    z = 0.6 * np.sqrt(np.clip(1 - 0.5 * u**2 - 0.5 * v**2, 0, None))
    pts = np.stack([0.8 * u, v, z], 1)
    pts[:8] = np.stack([np.zeros(8), np.linspace(0.3, -0.4, 8), np.linspace(0.75, 1.0, 8)], 1)
    return pts


def rel_err_deg(est, true) -> np.ndarray:
    """Angle between estimated and true rotations, both taken relative to frame 0 (camera axes)."""
    e, t = Rotation.from_rotvec(est), Rotation.from_rotvec(true)
    return np.degrees(((e * e[0].inv()) * (t * t[0].inv()).inv()).magnitude())


def test_batch_kabsch_recovers_similarity(rng):
    ref = rng.normal(size=(30, 3))
    R = Rotation.random(5, random_state=1).as_matrix()
    s = rng.uniform(50, 200, 5)
    c = rng.normal(size=(5, 3)) * 100
    pts = s[:, None, None] * np.einsum("tij,nj->tni", R, ref) + c[:, None]
    R2, s2, c2 = batch_kabsch(ref, pts)
    np.testing.assert_allclose(R2, R, atol=1e-9)
    np.testing.assert_allclose(s2, s, rtol=1e-9)
    np.testing.assert_allclose(c2, c, atol=1e-6)
    assert np.allclose(np.linalg.det(R2), 1.0)


def test_known_rotations_synthetic_shape_within_1_degree(rng):
    ref = face_shape(rng)
    true = np.radians(rng.uniform(-20, 20, (300, 3)))
    pts = project(ref, true, scale=90.0) + rng.normal(0, 0.7, (300, len(ref), 3))  # pixel noise
    fit = estimate_pose(pts)
    err = rel_err_deg(fit.rotvec, true)
    assert np.median(err) < 1.0
    assert np.percentile(err, 95) < 2.0
    # relative to the median pose: the median rotation vector is ~0
    assert np.all(np.abs(np.degrees(np.median(fit.rotvec, 0))) < 1.0)


@pytest.mark.parametrize("axis,image_motion", [
    (0, "nose down in the image"), (1, "nose to camera right"), (2, "top of head to image left")])
def test_axis_convention_signs(axis, image_motion):
    """+pitch = nose down, +yaw = nose to the speaker's left (camera right), +roll = top of the
    head to the speaker's right (image left) — checked on what the camera sees."""
    ref = face_shape()
    angles = np.zeros((40, 3))
    angles[20:, axis] = np.radians(10)
    pts = project(ref, angles, scale=100.0, center=(256, 256, 0))
    nose = pts[:, 7]  # nose tip (most +z point of the ridge)
    top = pts[:, np.argmax(ref[:, 1])]
    if axis == 0:
        assert nose[-1, 1] > nose[0, 1]  # image y grows downwards
    elif axis == 1:
        assert nose[-1, 0] > nose[0, 0]
    else:
        assert top[-1, 0] < top[0, 0]
    fit = estimate_pose(pts)
    change = np.degrees(fit.rotvec[-1] - fit.rotvec[0])
    assert change[axis] == pytest.approx(10.0, abs=0.3)
    others = [k for k in range(3) if k != axis]
    assert np.all(np.abs(change[others]) < 0.3)


def test_mirror_negates_yaw_and_roll_synthetic(rng):
    ref = face_shape(rng)
    true = np.radians(np.cumsum(rng.normal(0, 1.0, (200, 3)), 0))
    pts = project(ref, true, scale=90.0, center=(256, 256, 0))
    mirrored = pts.copy()
    mirrored[..., 0] = 512 - mirrored[..., 0]
    a = estimate_pose(pts).rotvec
    b = estimate_pose(mirrored).rotvec
    corr = [np.corrcoef(a[:, k], b[:, k])[0, 1] for k in range(3)]
    assert corr[0] > 0.99 and corr[1] < -0.99 and corr[2] < -0.99


def test_invalid_frames_are_nan_and_given_reference_is_used(rng):
    ref = face_shape(rng)
    true = np.radians(rng.uniform(-10, 10, (50, 3)))
    pts = project(ref, true)
    pts[10] = np.nan
    fit = estimate_pose(pts)
    assert np.all(np.isnan(fit.rotvec[10])) and np.isfinite(fit.rotvec[11]).all()
    fit2 = estimate_pose(pts, reference=ref)
    ok = np.arange(50) != 10
    assert np.median(rel_err_deg(fit2.rotvec[ok], true[ok])) < 0.01


def test_detect_cuts_on_synthetic_sequences(rng):
    ref = face_shape(rng)
    other = face_shape(np.random.default_rng(99))  # another "person"
    T = 120
    slow = np.radians(np.cumsum(rng.normal(0, 0.4, (T, 3)), 0))
    a = project(ref, slow, scale=90, center=(256, 256, 0))
    # shot 2 (frames 60..): the same person jumps to another place and size
    a[60:] = project(ref, slow[60:], scale=140, center=(150, 300, 0))
    # shot 3 (frames 95..): a different face at the same place
    a[95:] = project(other, slow[95:], scale=140, center=(150, 300, 0))
    a += rng.normal(0, 0.5, a.shape)
    valid = np.ones(T, bool)
    assert q.detect_cuts(a, valid) == [60, 95]
    # continuous fast motion is not a cut
    fast = np.radians(np.cumsum(rng.normal(0, 2.0, (T, 3)), 0))
    b = project(ref, fast, scale=90) + rng.normal(0, 0.5, (T, len(ref), 3))
    assert q.detect_cuts(b, valid) == []
    # missing frames are skipped over
    valid[30:40] = False
    assert q.detect_cuts(a, valid) == [60, 95]


def test_fill_gaps_and_split():
    t = np.arange(20) / 25.0
    r = np.stack([np.linspace(0, 0.19, 20), np.zeros(20), np.zeros(20)], 1)
    x = r.copy()
    x[3:6] = np.nan      # short: filled
    x[10:18] = np.nan    # long: kept missing
    x[0] = np.nan        # at the start: cannot interpolate
    filled, gaps = q.fill_gaps(x, t, max_gap=4)
    np.testing.assert_allclose(filled[3:6], r[3:6], atol=1e-9)
    assert np.isnan(filled[10:18]).all() and np.isnan(filled[0]).all()
    assert gaps == [(0, 1, False), (3, 6, True), (10, 18, False)]
    ok = np.all(np.isfinite(filled), 1)
    assert q.split_segments(ok, [], min_len=2) == [(1, 10), (18, 20)]
    assert q.split_segments(ok, [5], min_len=2) == [(1, 5), (5, 10), (18, 20)]
    assert q.split_segments(ok, [5], min_len=5) == [(5, 10)]


def test_lowpass_removes_high_frequency_keeps_slow_motion():
    fps = 25.0
    t = np.arange(500) / fps
    slow = 0.05 * np.sin(2 * np.pi * 1.0 * t)
    fast = 0.01 * np.sin(2 * np.pi * 11.0 * t)
    r = np.stack([slow + fast, slow, fast], 1)
    y = q.lowpass(r, fps, q.DEFAULT_LOWPASS_HZ)
    mid = slice(50, -50)
    np.testing.assert_allclose(y[mid, 1], slow[mid], atol=2e-3)
    assert np.std(y[mid, 2]) < 0.1 * np.std(fast)
    assert q.lowpass(r, fps, None) is not None and np.array_equal(q.lowpass(r, fps, None), r)
    assert q.jitter_deg(y).shape == (3,)


def test_confidence_drops_when_face_leaves_frame(rng):
    ref = face_shape(rng)
    T = 40
    pts = project(ref, np.zeros((T, 3)), scale=60, center=(256, 256, 0))
    shift = np.linspace(0, 400, T)
    pts[..., 0] += shift[:, None]
    res = np.full(T, 0.01)
    conf = q.confidence(pts, res, width=512, height=512)
    assert conf[0] == pytest.approx(1.0) and conf[-1] == 0.0
    assert np.all(np.diff(conf) <= 1e-12)
    assert q.confidence(np.full((3, 5, 3), np.nan), np.full(3, np.nan), width=10, height=10).sum() == 0


def test_missing_mediapipe_gives_install_hint(monkeypatch):
    from headmotion.video import landmarks

    monkeypatch.setitem(sys.modules, "mediapipe", None)
    with pytest.raises(MissingDependencyError, match=r"pip install headmotion\[video\]"):
        landmarks._import_mediapipe()


def test_bad_files_give_clear_errors(tmp_path):
    from headmotion.video.build import analyse_video

    junk = tmp_path / "junk.mp4"
    junk.write_bytes(np.random.default_rng(0).integers(0, 256, 5000, dtype=np.uint8).tobytes())
    with pytest.raises(FormatError, match="junk.mp4"):
        analyse_video(junk)
    empty = tmp_path / "empty.mp4"
    empty.write_bytes(b"")
    with pytest.raises(FormatError, match="empty"):
        analyse_video(empty)
    with pytest.raises(FormatError, match="not found"):
        analyse_video(tmp_path / "missing.mp4")


def test_real_corpus_speaker_names():
    from repo_scripts import load_script

    f = load_script("scripts/build_real_corpus.py", "build_real_corpus").speaker_for
    assert f("styletalk", "andrew_clip_2") == "andrew"
    assert f("styletalk", "feifeili_clip2_short") == "feifeili"
    assert f("dfrf", "french") == "french"
    assert f("sadtalker", "RD_Radio2_000") != f("sadtalker", "RD_Radio34_000")
    assert f("pc_avs", "Audio_Source_741400104") == f("pc_avs", "Pose_Source_741400163")
    assert f("mead_lrs3", "MEAD_M003_level_1_happy_024") == f("mead_lrs3", "MEAD_M003_level_1_disgusted_015")
    assert f("grid", "bbaf2n") != f("grid", "lbax4n")
