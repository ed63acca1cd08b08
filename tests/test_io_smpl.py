"""SMPL / SMPL-H / SMPL-X parameter files: files made here with known neck and
head rotations; the head-relative-to-chest composition is checked against scipy, the axes against
the convention of headmotion.rotations; wrong widths and missing rates are clear errors."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion.cli import main
from headmotion.errors import FormatError, HeadMotionError, ParameterError
from headmotion.io import load_motion, motion_info, save_motion
from headmotion.io.motion import detect_format
from headmotion.io.smpl import HEAD, NECK


def make_poses(T, width, rng, *, neck=None, head=None):
    """Random body poses (every joint turned, root included) with chosen neck/head rotations."""
    p = rng.normal(0, 0.3, (T, width))
    if neck is not None:
        p[:, 3 * NECK:3 * NECK + 3] = neck
    if head is not None:
        p[:, 3 * HEAD:3 * HEAD + 3] = head
    return p


@pytest.mark.parametrize("width,model,rate_key", [(72, "smpl", "mocap_framerate"),
                                                  (156, "smpl-h", "mocap_framerate"),
                                                  (165, "smpl-x", "mocap_frame_rate")])
def test_composition_against_scipy(tmp_path, rng, width, model, rate_key):
    T = 120
    neck = rng.normal(0, 0.2, (T, 3))
    head = rng.normal(0, 0.3, (T, 3))
    p = tmp_path / "take.npz"
    np.savez(p, poses=make_poses(T, width, rng, neck=neck, head=head), trans=rng.normal(size=(T, 3)),
             betas=np.zeros(10), gender=np.array("neutral"), **{rate_key: np.array(120.0)})
    assert detect_format(p) == "smpl"
    m = load_motion(p)
    assert m.fps == 120.0 and len(m) == T and m.meta["model"] == model
    expect = Rotation.from_rotvec(neck) * Rotation.from_rotvec(head)  # parent (neck) first
    err = (Rotation.from_rotvec(np.array(m.rotvec)).inv() * expect).magnitude()
    assert err.max() < 1e-9
    # the order matters: head ∘ neck would differ
    wrong = Rotation.from_rotvec(head) * Rotation.from_rotvec(neck)
    assert (Rotation.from_rotvec(np.array(m.rotvec)).inv() * wrong).magnitude().max() > 1e-3


def test_axes_are_ours(tmp_path, rng):
    """SMPL's body frame is +x left, +y up, +z forward: a neck turn of +20° about x is a nod down
    (positive pitch), about y a turn to the speaker's left (positive yaw), about z a tilt of the
    top of the head to the speaker's right (positive roll)."""
    T = 3
    neck = np.radians([[20, 0, 0], [0, 20, 0], [0, 0, 20]])
    p = tmp_path / "axes.npz"
    np.savez(p, poses=make_poses(T, 165, rng, neck=neck, head=np.zeros((T, 3))), mocap_frame_rate=30)
    m = load_motion(p)
    R = m.as_matrix()
    nose = R @ np.array([0, 0, 1.0])  # the forward axis of the head, in torso axes
    top = R @ np.array([0, 1.0, 0])
    assert nose[0, 1] < -0.3  # pitch +20°: nose goes down
    assert nose[1, 0] > 0.3  # yaw +20°: nose to the speaker's left (+x)
    assert top[2, 0] < -0.3  # roll +20°: top of the head to the speaker's right (−x)
    np.testing.assert_allclose(np.degrees(m.as_euler("YXZ")), [[0, 20, 0], [20, 0, 0], [0, 0, 20]], atol=1e-9)


def test_pose_body_and_joint_axis_layouts(tmp_path, rng):
    T = 10
    neck, head = rng.normal(0, 0.2, (T, 3)), rng.normal(0, 0.2, (T, 3))
    full = make_poses(T, 165, rng, neck=neck, head=head)
    np.savez(tmp_path / "amass.npz", root_orient=full[:, :3], pose_body=full[:, 3:66], mocap_frame_rate=60.0)
    np.savez(tmp_path / "tj3.npz", poses=full.reshape(T, 55, 3), mocap_frame_rate=np.array([60.0]))
    a, b = load_motion(tmp_path / "amass.npz"), load_motion(tmp_path / "tj3.npz")
    np.testing.assert_allclose(a.rotvec, b.rotvec, atol=1e-12)
    assert a.fps == b.fps == 60.0


def test_nan_frames_are_gaps(tmp_path, rng):
    T = 100
    poses = make_poses(T, 165, rng, neck=np.zeros((T, 3)), head=np.tile([0.1, 0.0, 0.0], (T, 1)))
    poses[40:42] = np.nan
    np.savez(tmp_path / "gap.npz", poses=poses, mocap_frame_rate=30)
    m = load_motion(tmp_path / "gap.npz")
    assert m.meta["gaps"]["filled_frames"] == 2
    np.testing.assert_allclose(m.rotvec[40:42], [[0.1, 0, 0]] * 2, atol=1e-12)


def test_wrong_width_no_rate_and_bad_rate(tmp_path, rng):
    np.savez(tmp_path / "w.npz", poses=rng.normal(size=(10, 99)), mocap_frame_rate=30)
    with pytest.raises(FormatError, match=r"w\.npz: 'poses' has shape \(10, 99\); expected \(frames, 72\) SMPL"):
        load_motion(tmp_path / "w.npz")
    np.savez(tmp_path / "r.npz", poses=rng.normal(size=(10, 165)), betas=np.zeros(10))
    with pytest.raises(FormatError, match=r"r\.npz: no frame rate: none of mocap_frame_rate, mocap_framerate"):
        load_motion(tmp_path / "r.npz")
    assert load_motion(tmp_path / "r.npz", fps=30).fps == 30.0
    with pytest.raises(ParameterError, match=r"r\.npz: fps= 0 is not a finite rate between 1 and 1000"):
        load_motion(tmp_path / "r.npz", fps=0)
    for bad in (0.0, np.inf, 1e5):
        np.savez(tmp_path / "b.npz", poses=rng.normal(size=(10, 165)), mocap_frame_rate=bad)
        with pytest.raises(FormatError, match="mocap_frame_rate = .*expected one frame rate within 1–1000"):
            load_motion(tmp_path / "b.npz")
    np.savez(tmp_path / "s.npz", poses=np.array(["a", "b"]), mocap_frame_rate=30)
    with pytest.raises(HeadMotionError, match="poses"):
        load_motion(tmp_path / "s.npz")
    np.savez(tmp_path / "e.npz", poses=np.zeros((0, 165)), mocap_frame_rate=30)
    with pytest.raises(FormatError, match="no frames"):
        load_motion(tmp_path / "e.npz")


def test_native_npz_still_native(tmp_path, rng):
    from headmotion.types import Motion

    save_motion(Motion(rng.normal(0, 0.1, (20, 3)), 25.0), tmp_path / "ours.npz")
    assert detect_format(tmp_path / "ours.npz") == "npz"


def test_cli_info_convert_and_corpus_import(tmp_path, rng, capsys):
    T, fps = 30 * 6, 30.0
    t = np.arange(T) / fps
    head = np.stack([0.2 * np.sin(2 * np.pi * 0.5 * t), 0.3 * np.sin(2 * np.pi * 0.3 * t), 0 * t], 1)
    np.savez(tmp_path / "take1.npz", poses=make_poses(T, 165, rng, neck=np.zeros((T, 3)), head=head),
             mocap_frame_rate=fps, gender=np.array("female"))
    assert main(["info", str(tmp_path / "take1.npz")]) == 0
    out = capsys.readouterr().out
    assert "smpl" in out and "180" in out
    assert main(["convert", str(tmp_path / "take1.npz"), str(tmp_path / "take1.bvh")]) == 0
    back = load_motion(tmp_path / "take1.bvh")
    np.testing.assert_allclose(back.rotvec, head, atol=1e-6)
    from headmotion.io import save_audio
    from headmotion.types import Audio

    save_audio(Audio(0.1 * np.sin(2 * np.pi * 140 * np.arange(6 * 16000) / 16000), 16000), tmp_path / "take1.wav")
    c = tmp_path / "corpus"
    assert main(["corpus", "import", str(tmp_path / "take1.npz"), str(tmp_path / "take1.wav"), "-o", str(c),
                 "--speaker", "s1"]) == 0
    assert main(["corpus", "check", str(c)]) == 0
    info = motion_info(tmp_path / "take1.npz")
    assert info["format"] == "smpl" and info["model"] == "smpl-x" and info["fps"] == 30.0
    # a wrong-width file: a one-line error from the CLI, no traceback
    np.savez(tmp_path / "bad.npz", poses=np.zeros((5, 70)), mocap_frame_rate=30)
    assert main(["convert", str(tmp_path / "bad.npz"), str(tmp_path / "bad.bvh")]) != 0
    err = capsys.readouterr().err
    assert "bad.npz" in err and "(5, 70)" in err and "Traceback" not in err
