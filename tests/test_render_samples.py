"""Several samples side by side: K motions of one speech as a labelled grid MP4
with the speech; on real speech, K seeds of the shipped default model."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.render.samples import render_samples, sample_labels
from headmotion.types import Audio, Motion

ROOT = Path(__file__).resolve().parents[1]


def test_labels():
    assert sample_labels(2) == ["sample 1", "sample 2"]
    assert sample_labels(2, [7, 8]) == ["sample 1 · seed 7", "sample 2 · seed 8"]
    with pytest.raises(ParameterError, match="2 seeds given for 3"):
        sample_labels(3, [1, 2])


def test_grid_of_samples_cells_follow_their_motion(gl, tmp_path):
    """Three samples at 100 fps → a 1×3 grid at 25 fps; the still sample's cell stays still, the
    others move; the speech is muxed in."""
    from headmotion.render.video import probe, read_frames

    fps, n = 100.0, 200
    t = np.arange(n) / fps
    moving = np.zeros((n, 3))
    moving[:, 1] = 0.5 * np.sin(2 * np.pi * 0.5 * t)
    nod = np.zeros((n, 3))
    nod[:, 0] = 0.4 * np.sin(2 * np.pi * 0.5 * t)
    samples = [Motion(moving, fps), Motion(np.zeros((n, 3)), fps), Motion(nod, fps)]
    sr = 16000
    audio = Audio((0.1 * np.sin(2 * np.pi * 200 * np.arange(2 * sr) / sr)).astype(np.float32), sr)
    out = tmp_path / "samples.mp4"
    info = render_samples(samples, out, audio=audio, seeds=[0, 1, 2], size=(160, 120), style="silhouette")
    assert info["fps"] == 25.0 and info["frames"] == 50 and info["size"] == (480, 120)
    p = probe(out)
    assert p["audio"] is not None and abs(p["duration"] - 2.0) < 0.1
    frames = read_frames(out)
    assert frames.shape == (50, 120, 480, 3)
    cells = [frames[:, 30:, k * 160:(k + 1) * 160].astype(int) for k in range(3)]
    change = [np.abs(c[12] - c[0]).mean() for c in cells]  # 0.5 s apart: the sines at their peak
    assert change[1] < 0.1 and change[0] > 1 and change[2] > 1, change
    with pytest.raises(ParameterError, match="at least one"):
        render_samples([], tmp_path / "x.mp4")


@pytest.mark.slow
def test_default_model_samples_on_real_speech(gl, shared_data, tmp_path):
    from headmotion.io.audio import load_audio
    from headmotion.render.video import read_frames
    from headmotion.systems.base import load_model

    model = load_model(ROOT / "src" / "headmotion" / "data" / "default_model.hmz")
    audio = load_audio(shared_data / "speech" / "jfk.flac", sample_rate=model.sample_rate_).slice_seconds(0, 3)
    seeds = [0, 1, 2, 3]
    samples = [model.predict(audio, seed=s) for s in seeds]
    out = tmp_path / "jfk_samples.mp4"
    info = render_samples(samples, out, audio=audio, seeds=seeds, size=(160, 120))
    assert info["size"] == (640, 120) and info["fps"] == 25.0
    frames = read_frames(out)
    assert len(frames) == info["frames"]
