"""Gain and offset (motion/control.py), frame times of the resamplers, the pad/trim helper and
integer PCM in Audio (known answers)."""

import numpy as np
import pytest

from headmotion.align import fit_length, resample_track
from headmotion.errors import ParameterError
from headmotion.motion.control import apply_gain, mean_pose_of
from headmotion.rotations import pitch_yaw_roll_to_rotvec, rotvec_to_pitch_yaw_roll
from headmotion.types import Audio, FeatureTrack, Motion


def _motion(T=500, fps=100.0):
    t = np.arange(T) / fps
    pyr = np.column_stack([0.05 + 0.1 * np.sin(2 * np.pi * 0.7 * t), -0.02 + 0.08 * np.sin(2 * np.pi * 1.3 * t + 1),
                           0.01 + 0.04 * np.cos(2 * np.pi * 0.4 * t)])
    return Motion(pitch_yaw_roll_to_rotvec(pyr[:, 0], pyr[:, 1], pyr[:, 2]), fps), pyr


def test_gain_scales_sd_exactly_and_offset_moves_the_mean_exactly():
    m, pyr = _motion()
    pose = np.array([0.03, 0.0, 0.02])
    out = rotvec_to_pitch_yaw_roll(apply_gain(m, pose, gain=(2.0, 0.5, 1.0)).rotvec)
    np.testing.assert_allclose(out.std(axis=0), pyr.std(axis=0) * [2.0, 0.5, 1.0], rtol=1e-9)
    # about the mean pose: out - pose = g (in - pose)
    np.testing.assert_allclose(out - pose, (pyr - pose) * [2.0, 0.5, 1.0], atol=1e-12)
    shifted = rotvec_to_pitch_yaw_roll(apply_gain(m, pose, offset=(0.1, -0.05, 0.0)).rotvec)
    np.testing.assert_allclose(shifted.mean(axis=0) - pyr.mean(axis=0), [0.1, -0.05, 0.0], atol=1e-12)
    np.testing.assert_allclose(shifted.std(axis=0), pyr.std(axis=0), rtol=1e-9)


def test_gain_zero_is_a_still_head_at_the_mean_pose_plus_offset():
    m, _ = _motion()
    pose = np.array([0.03, -0.01, 0.02])
    still = apply_gain(m, pose, gain=0.0, offset=0.01)
    np.testing.assert_allclose(still.rotvec, np.tile(pitch_yaw_roll_to_rotvec(*(pose + 0.01)), (len(m), 1)), atol=1e-14)
    assert apply_gain(m, pose) is m  # identity: bit-identical
    for bad in ((1.0, 2.0), "loud", np.nan):
        with pytest.raises(ParameterError, match="gain"):
            apply_gain(m, pose, gain=bad)


def test_mean_pose_of_training_motions():
    m, pyr = _motion()
    np.testing.assert_allclose(mean_pose_of([m.rotvec[:200], m.rotvec[200:]]), pyr.mean(axis=0), atol=1e-12)


def test_one_frame_time_convention_for_every_resampler():
    """Frame t at time t / fps: a ramp resampled 25 → 100 fps by either resampler lands on the same
    times (before this, resample_track used (t + 0.5) / fps, 15 ms later at 25 → 100 fps)."""
    T, fps = 50, 25.0
    ramp = 0.01 * np.arange(T, dtype=np.float64)  # value = 0.25 * time in seconds
    mot = Motion(np.column_stack([ramp, np.zeros(T), np.zeros(T)]), fps).resample(100.0)
    tr = resample_track(FeatureTrack(ramp[:, None].astype(np.float32), fps, ("x",)), 100.0)
    n = min(len(mot), len(tr)) - 4  # past the last input frame both hold it
    expected = 0.25 * np.arange(n) / 100.0
    np.testing.assert_allclose(mot.rotvec[:n, 0], expected, atol=1e-9)
    np.testing.assert_allclose(tr.values[:n, 0], expected, atol=1e-6)


def test_fit_length_trims_and_pads_with_the_last_frame():
    a = np.arange(6).reshape(3, 2)
    np.testing.assert_array_equal(fit_length(a, 2), a[:2])
    np.testing.assert_array_equal(fit_length(a, 5), np.vstack([a, a[-1:], a[-1:]]))
    assert fit_length(np.zeros((0, 2)), 3).shape == (3, 2)


def test_audio_scales_integer_pcm():
    a = Audio(np.array([0, 16384, -32768, 32767], dtype=np.int16), 16000)
    np.testing.assert_allclose(a.samples, [0.0, 0.5, -1.0, 32767 / 32768], rtol=0, atol=1e-7)
    b = Audio(np.array([128, 255, 0], dtype=np.uint8), 8000)
    np.testing.assert_allclose(b.samples, [0.0, 127 / 128, -1.0], atol=1e-7)
    c = Audio(np.array([2 ** 30], dtype=np.int32), 8000)
    np.testing.assert_allclose(c.samples, [0.5])
