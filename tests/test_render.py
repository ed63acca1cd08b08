"""Offscreen head rendering and preview videos (thesis §4.2.3).

The axis tests render pure pitch, yaw and roll and check where the black boxes over the eyes and
mouth move in the image: the camera faces the speaker, so the speaker's left is the image's right.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.render import mesh as hm_mesh
from headmotion.types import Audio, Motion


# -- the mesh (no OpenGL needed) -------------------------------------------------------------
def test_mesh_is_a_head_not_a_ball():
    m = hm_mesh.build_head_mesh()
    names = [p.name for p in m.parts]
    assert names == ["head", "ears", "neck", "torso", "mask"]
    head = m.part("head")
    lo, hi = head.positions.min(0), head.positions.max(0)
    height, width, depth = hi[1] - lo[1], hi[0] - lo[0], hi[2] - lo[2]
    assert 0.20 < height < 0.25 and 0.14 < width < 0.18 and 0.19 < depth < 0.25
    # the nose tip is the front-most point, on the mid-line, below the eyes
    tip = head.positions[np.argmax(head.positions[:, 2])]
    assert abs(tip[0]) < 0.005
    assert hm_mesh.HEAD_CENTER[1] - 0.04 < tip[1] < hm_mesh.HEAD_CENTER[1]
    # the head is much wider at the cheekbones than at the chin (a jaw, not an ellipsoid)
    p = head.positions - hm_mesh.HEAD_CENTER
    front = p[:, 2] > 0.02
    w_cheek = np.ptp(p[front & (np.abs(p[:, 1] + 0.01) < 0.004), 0])
    w_chin = np.ptp(p[front & (np.abs(p[:, 1] + 0.095) < 0.004), 0])
    assert w_chin < 0.8 * w_cheek
    # hair on top, skin on the face
    top = np.argmax(head.positions[:, 1])
    assert head.materials[top] == hm_mesh.HAIR and head.materials[np.argmax(head.positions[:, 2])] == hm_mesh.SKIN
    # normals unit and outward
    assert np.allclose(np.linalg.norm(head.normals, axis=1), 1, atol=1e-4)
    assert np.mean(np.sum(head.normals * p, axis=1) > 0) > 0.97
    # head moves with the head, torso stays, neck blends
    assert np.all(m.part("torso").weights == 0) and np.all(head.weights == 1)
    w = m.part("neck").weights
    assert w.min() == 0 and w.max() == 1


def test_mesh_bytes_round_trip():
    m = hm_mesh.build_head_mesh(detail=0)
    back = hm_mesh.mesh_from_bytes(hm_mesh.mesh_to_bytes(m))
    for a, b in zip(m.parts, back.parts):
        assert a.name == b.name
        np.testing.assert_array_equal(a.indices, b.indices)
        np.testing.assert_allclose(a.positions, b.positions)


def test_import_is_lazy():
    code = ("import sys, headmotion.render, headmotion.cli.render_cmds; "
            "print(any(m.startswith(('moderngl', 'matplotlib')) for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# -- OpenGL ------------------------------------------------------------------------------------
def _mask_stats(img):
    """Centroid (x, y) of the black-box pixels, their x–row covariance and count."""
    m = img.max(axis=2) < 10
    ys, xs = np.nonzero(m)
    return xs.mean(), ys.mean(), np.cov(xs, ys)[0, 1], int(m.sum())


@pytest.fixture(scope="module")
def smooth_renderer(gl):
    from headmotion.render.offscreen import HeadRenderer

    with HeadRenderer(size=(320, 240), style="smooth") as r:
        yield r


def test_axis_convention_pitch_yaw_roll(smooth_renderer):
    r = smooth_renderer
    x0, y0, c0, n0 = _mask_stats(r.render([[0, 0, 0]]))
    assert n0 > 500 and abs(x0 - 160) < 2  # centred, facing the camera
    # positive pitch = nose down: the boxes move down the image
    x, y, _, _ = _mask_stats(r.render([[0.3, 0, 0]]))
    assert y > y0 + 10 and abs(x - x0) < 1
    # positive yaw = nose to the speaker's left = the image's right
    x, y, _, _ = _mask_stats(r.render([[0, 0.3, 0]]))
    assert x > x0 + 8 and abs(y - y0) < 3
    # positive roll = top of head to the speaker's right = image left: the eye box (top) is left
    # of the mouth box (bottom), so x grows with the row
    x, y, c, _ = _mask_stats(r.render([[0, 0, 0.3]]))
    assert c > 20 and abs(c0) < 1 and x < x0 - 5
    # translation +x (speaker's left) moves the head to the image's right
    x, _, _, _ = _mask_stats(r.render([[0, 0, 0]], [[0.03, 0, 0]]))
    assert x > x0 + 10


def test_rotation_matrices_accepted(smooth_renderer):
    from headmotion.rotations import rotvec_to_matrix

    a = smooth_renderer.render([[0.1, -0.2, 0.05]])
    b = smooth_renderer.render(rotvec_to_matrix([[0.1, -0.2, 0.05]]))
    assert np.mean(np.abs(a.astype(int) - b.astype(int))) < 0.5


def test_styles_and_mask_option(gl):
    from headmotion.render.offscreen import HeadRenderer

    with HeadRenderer(size=(160, 120), style="silhouette") as r:
        img = r.render([[0, 0, 0]])
    colours = np.unique(img.reshape(-1, 3), axis=0)
    assert len(colours) == 2 and (colours[0] == 0).all() and (colours[-1] == 255).all()
    black = (img.max(2) == 0).mean()
    assert 0.15 < black < 0.6
    with HeadRenderer(size=(160, 120), style="textured") as r:
        img = r.render([[0, 0, 0]]).astype(int)
    skin = (img[..., 0] > img[..., 1] + 20) & (img[..., 1] > img[..., 2])  # warm skin tones
    assert skin.mean() > 0.08
    assert (img.max(2) < 10).sum() > 100  # the boxes
    with HeadRenderer(size=(160, 120), style="smooth", mask=False) as r:
        img = r.render([[0, 0, 0]])
    assert (img.max(2) < 10).sum() == 0


def test_grid_and_labels(gl):
    from headmotion.render.offscreen import HeadRenderer

    with HeadRenderer(size=(160, 120), style="smooth", grid=(1, 2), labels=["A", "B"]) as r:
        img = r.render([[0, 0, 0], [0, 0.5, 0]])
        plain = HeadRenderer(size=(160, 120), style="smooth", grid=(1, 2))
        ref = plain.render([[0, 0, 0], [0, 0.5, 0]])
        plain.release()
    assert img.shape == (120, 320, 3)
    left, right = img[:, :160], img[:, 160:]
    assert np.mean(np.abs(left.astype(int) - right.astype(int))) > 1
    # the labels change the top-left corner of each cell and nothing in the middle
    d = np.abs(img.astype(int) - ref.astype(int)).max(2)
    assert d[:20, :40].max() > 50 and d[:20, 160:200].max() > 50
    assert d[40:, :].max() == 0


def test_bad_parameters(gl):
    from headmotion.render.offscreen import HeadRenderer, parse_size

    with pytest.raises(ParameterError, match="style"):
        HeadRenderer(style="cartoon")
    with pytest.raises(ParameterError, match="even"):
        parse_size("641x480")
    with pytest.raises(ParameterError, match="WIDTHxHEIGHT"):
        parse_size("big")
    assert parse_size("320x240") == (320, 240)


# -- video -----------------------------------------------------------------------------------
def _step_motion(fps=25.0, n=40, step_at=15):
    rv = np.zeros((n, 3))
    rv[step_at:, 1] = 0.4  # sudden turn to the speaker's left at frame 15
    return Motion(rv, fps)


def _click_audio(at_s, dur_s, sr=16000):
    x = np.zeros(int(dur_s * sr), np.float32)
    i = int(round(at_s * sr))
    t = np.arange(int(0.2 * sr)) / sr
    x[i:i + len(t)] = 0.5 * np.sin(2 * np.pi * 1000 * t)
    return Audio(x, sr)


def test_render_video_h264_with_audio_in_sync(gl, tmp_path):
    from headmotion.render import render_video
    from headmotion.render.video import ffmpeg_exe, probe, read_frames

    fps, n, step = 25.0, 40, 15
    motion = _step_motion(fps, n, step)
    audio = _click_audio(step / fps, n / fps + 0.5)  # longer audio: cut to the motion
    out = tmp_path / "clip.mp4"
    info = render_video(motion, out, audio=audio, style="smooth", size=(320, 240))
    assert info["frames"] == n and out.is_file()
    assert not list(tmp_path.glob(".*part*"))
    p = probe(out)
    assert p["video"].startswith("h264") and "yuv420p" in p["video"] and "320x240" in p["video"]
    assert p["audio"].startswith("aac")
    assert abs(p["duration"] - n / fps) < 0.08
    frames = read_frames(out)
    assert len(frames) == n
    xs = np.array([_mask_stats(f)[0] for f in frames])
    video_step = int(np.argmax(xs > (xs[0] + xs[-1]) / 2))
    assert video_step == step
    # the audio onset in the file
    wav = subprocess.run([ffmpeg_exe(), "-v", "error", "-i", str(out), "-f", "s16le", "-ac", "1",
                          "-ar", "16000", "-"], capture_output=True, check=True).stdout
    a = np.abs(np.frombuffer(wav, np.int16).astype(float))
    onset = np.argmax(a > 0.2 * a.max()) / 16000
    assert abs(onset - step / fps) < 1 / fps  # less than one frame apart


def test_render_video_grid_labels_and_resampling(gl, tmp_path):
    from headmotion.render import render_video
    from headmotion.render.video import probe, read_frames

    a = _step_motion(25.0, 20, 5)
    b = Motion(np.zeros((40, 3)), 50.0)  # another rate: resampled to 25 fps
    out = tmp_path / "grid.mp4"
    info = render_video([a, b], out, labels=["truth", "still"], style="silhouette", size=(160, 120))
    assert info["size"] == (320, 120) and info["frames"] == 20
    assert probe(out)["audio"] is None
    frames = read_frames(out)
    assert frames.shape == (20, 120, 320, 3)
    # the right cell (still head) does not change; the left one does
    assert np.abs(frames[-1, 30:, 160:].astype(int) - frames[0, 30:, 160:]).mean() < 1
    assert np.abs(frames[-1, 30:, :160].astype(int) - frames[0, 30:, :160]).mean() > 3
    with pytest.raises(ParameterError, match="labels"):
        render_video([a, b], tmp_path / "x.mp4", labels=["one"])
    assert not (tmp_path / "x.mp4").exists()


def test_render_video_audio_file_path(gl, tmp_path):
    import soundfile as sf

    from headmotion.render import render_video
    from headmotion.render.video import probe

    au = _click_audio(0.1, 0.6)
    wav = tmp_path / "s.wav"
    sf.write(wav, au.samples, au.sample_rate)
    out = tmp_path / "c.mp4"
    render_video(Motion(np.zeros((10, 3)), 20.0), out, audio=wav, size=(96, 64))
    p = probe(out)
    assert p["audio"] is not None and abs(p["duration"] - 0.5) < 0.08
    from headmotion.errors import AudioLoadingError

    with pytest.raises(AudioLoadingError):
        render_video(Motion(np.zeros((10, 3)), 20.0), out, audio=tmp_path / "missing.wav")


def test_translation_is_about_the_clip_mean(gl, tmp_path):
    from headmotion.render import render_video
    from headmotion.render.video import read_frames

    n = 10
    tr = np.zeros((n, 3))
    tr[:, 1] = 0.25  # a constant offset from the torso: must not lift the head off the neck
    tr[5:, 0] += 0.04  # then a 4 cm shift to the speaker's left (image right)
    m = Motion(np.zeros((n, 3)), 10.0, translation=tr)
    render_video(m, tmp_path / "t.mp4", style="smooth", size=(160, 120))
    f = read_frames(tmp_path / "t.mp4")
    x0, y0, _, _ = _mask_stats(f[0])
    x1, y1, _, _ = _mask_stats(f[-1])
    ref = _mask_stats(read_frames_still(tmp_path))
    assert abs(y0 - ref[1]) < 2 and x1 > x0 + 3
    render_video(m, tmp_path / "r.mp4", style="smooth", size=(160, 120), translation=False)
    g = read_frames(tmp_path / "r.mp4")
    assert abs(_mask_stats(g[-1])[0] - _mask_stats(g[0])[0]) < 0.5


def read_frames_still(tmp_path):
    from headmotion.render import render_video
    from headmotion.render.video import read_frames

    render_video(Motion(np.zeros((2, 3)), 10.0), tmp_path / "s.mp4", style="smooth", size=(160, 120))
    return read_frames(tmp_path / "s.mp4")[0]
