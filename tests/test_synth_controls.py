"""``headmotion synth`` controls: per-axis gain and offset, --still, --style-from,
--neck-share and the K-sample grid, with known answers on the shipped default model."""

import numpy as np
import pytest

from headmotion.cli import main
from headmotion.io import load_motion
from headmotion.rotations import rotvec_to_pitch_yaw_roll
from headmotion.synthesis import Controls
from headmotion.types import Motion

pytestmark = pytest.mark.slow


def _angles(path):
    return np.degrees(rotvec_to_pitch_yaw_roll(load_motion(path).rotvec))


@pytest.fixture(scope="module")
def speech(examples_dir):
    return examples_dir / "speech" / "speech_male.wav"


def test_per_axis_overrides_one_axis():
    assert Controls.parse(gain=1.2, gain_pyr=(None, 0.5, None)).gain == (1.2, 0.5, 1.2)
    assert Controls.parse(gain=(1, 2, 3), gain_pyr=(None, None, 7)).gain == (1.0, 2.0, 7.0)


def test_gain_and_offset_per_axis_change_sd_and_mean_exactly(speech, tmp_path):
    base, ctl = tmp_path / "base.npz", tmp_path / "ctl.npz"
    assert main(["synth", str(speech), "-o", str(base), "--seed", "3"]) == 0
    assert main(["synth", str(speech), "-o", str(ctl), "--seed", "3", "--gain", "1.5", "--gain-yaw", "0.5",
                 "--offset-pitch", "4", "--offset-roll", "-2"]) == 0
    a, b = _angles(base), _angles(ctl)
    np.testing.assert_allclose(b.std(axis=0), a.std(axis=0) * [1.5, 0.5, 1.5], rtol=1e-3, atol=1e-4)
    # the mean moves by the offset plus the gain's scaling about the model's (training) mean pose
    from headmotion.cli.synth_cmds import default_model_path
    from headmotion.systems import load_model

    mp = np.degrees(load_model(default_model_path()).mean_pose_)
    expect = mp + np.array([1.5, 0.5, 1.5]) * (a.mean(axis=0) - mp) + [4.0, 0.0, -2.0]
    np.testing.assert_allclose(b.mean(axis=0), expect, atol=1e-3)


def test_still_does_not_move_and_has_the_length(speech, tmp_path):
    moving, still = tmp_path / "m.npz", tmp_path / "s.npz"
    assert main(["synth", str(speech), "-o", str(moving)]) == 0
    assert main(["synth", str(speech), "-o", str(still), "--still"]) == 0
    m, s = load_motion(moving), load_motion(still)
    assert len(s) == len(m) and s.fps == m.fps
    assert np.all(s.rotvec == 0.0)
    assert main(["synth", str(speech), "-o", str(still), "--still", "--offset-yaw", "10"]) == 0
    a = _angles(still)
    np.testing.assert_allclose(a, np.tile([0.0, 10.0, 0.0], (len(a), 1)), atol=1e-9)


def test_style_from_reference_takes_its_amplitude(speech, tmp_path):
    ref = tmp_path / "ref.npz"
    from headmotion.io import save_motion

    # a reference that moves 8 deg SD in yaw with a slow sway, 3 deg in pitch and roll
    t = np.arange(750) / 25.0
    pyr = np.radians(np.stack([3 * 2 ** 0.5 * np.sin(2 * np.pi * 0.3 * t), 8 * 2 ** 0.5 * np.sin(2 * np.pi * 0.2 * t),
                               3 * 2 ** 0.5 * np.sin(2 * np.pi * 0.4 * t)], axis=1))
    from headmotion.rotations import pitch_yaw_roll_to_rotvec

    save_motion(Motion(pitch_yaw_roll_to_rotvec(pyr[:, 0], pyr[:, 1], pyr[:, 2]), 25.0), ref)
    out, base = tmp_path / "styled.npz", tmp_path / "base.npz"
    assert main(["synth", str(speech), "-o", str(base)]) == 0
    assert main(["synth", str(speech), "-o", str(out), "--style-from", str(ref)]) == 0
    sd_base, sd = _angles(base).std(axis=0), _angles(out).std(axis=0)
    target = _angles(ref).std(axis=0)
    # at least half-way from the unstyled towards the reference (the style transfer's acceptance rule)
    assert np.all(np.abs(sd - target) <= 0.5 * np.abs(sd_base - target) + 1e-6)


def test_neck_share_and_samples_grid(speech, tmp_path):
    out, vid = tmp_path / "head.bvh", tmp_path / "grid.mp4"
    assert main(["synth", str(speech), "-o", str(out), "--neck-share", "0.5", "--samples", "2",
                 "--video", str(vid)]) == 0
    assert (tmp_path / "head_1.bvh").exists() and (tmp_path / "head_2.bvh").exists() and vid.stat().st_size > 0
    assert main(["synth", str(speech), "-o", str(tmp_path / "x.npz"), "--neck-share", "0.5"]) != 0
    assert main(["synth", str(speech), "-o", str(out), "--neck-share", "1.5"]) != 0


def test_stream_per_axis_gain_and_offset(speech):
    import json
    import subprocess
    import sys

    import soundfile as sf

    x, sr = sf.read(speech, dtype="int16")
    runs = []
    for extra in ([], ["--gain-yaw", "0", "--offset-yaw", "5"]):
        r = subprocess.run([sys.executable, "-m", "headmotion", "stream", "--sample-rate", str(sr), *extra],
                           input=x.astype("<i2").tobytes(), capture_output=True, timeout=120, check=True)
        runs.append(np.array([json.loads(line)["pitch_yaw_roll_deg"] for line in r.stdout.decode().splitlines()]))
    a, b = runs
    assert len(a) == len(b) > 100
    np.testing.assert_allclose(b[:, [0, 2]], a[:, [0, 2]], atol=1e-3)
    assert b[:, 1].std() < 1e-6 and abs(b[:, 1].mean() - 5.0) < 1.0  # held at the mean pose + 5 deg
