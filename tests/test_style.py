"""Style from a reference: known answers on sinusoids, the half-way rule on real
recordings (the shipped default model's output styled like ZEGGS mocap and like talking videos)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.motion.style import BAND_NAMES, StyleProfile, apply_style, band_split, style_profile
from headmotion.rotations import pitch_yaw_roll_to_rotvec
from headmotion.types import Motion
from headmotion.video.reference import load_style_reference

ROOT = Path(__file__).resolve().parents[1]
CORPUS = Path.home() / ".cache" / "headmotion" / "corpus" / "talking_video"

# one frequency in the middle of each band (Hz), away from the crossovers
F_BANDS = (0.25, 0.9, 2.5, 7.0)


def _sines(amps, fps, seconds, phases=(0.3, 1.1, 2.0, 0.7), freqs=F_BANDS):
    t = np.arange(int(round(seconds * fps))) / fps
    return t, sum(a * np.sin(2 * np.pi * f * t + p) for a, f, p in zip(amps, freqs, phases))


def _motion_deg(pitch, yaw, roll, fps):
    return Motion(pitch_yaw_roll_to_rotvec(pitch, yaw, roll, degrees=True), fps)


def _component(x, t, f):
    """Amplitude and phase of the sinusoid at ``f`` in ``x`` (least squares)."""
    A = np.stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t), np.ones_like(t)], 1)
    c = np.linalg.lstsq(A, x, rcond=None)[0]
    return np.hypot(c[0], c[1]), np.arctan2(c[1], c[0])


def test_band_split_sums_to_signal_and_separates_sines():
    fps = 100.0
    t, x = _sines((1.0, 2.0, 0.5, 0.25), fps, 40.0)
    b = band_split(x, fps)
    assert b.shape == (4, len(t), 1)
    np.testing.assert_allclose(b.sum(axis=0)[:, 0], x, atol=1e-12)
    for k in range(len(F_BANDS)):
        _, xk = _sines([1.0 if j == k else 0.0 for j in range(4)], fps, 40.0)
        # each band holds its own sine; the mirror extension makes a kink at the ends, which the
        # slow bands smear over a few seconds (like any zero-phase filter's end effects)
        inner = slice(1000, -1000)
        np.testing.assert_allclose(b[k, inner, 0], [1.0, 2.0, 0.5, 0.25][k] * xk[inner], atol=1e-3)


def test_profile_of_sines_known_answer():
    fps = 50.0
    amps = np.array([1.0, 2.0, 0.5, 0.25])
    _, p = _sines(amps, fps, 40.0)
    _, y = _sines(amps[::-1], fps, 40.0)
    prof = style_profile(_motion_deg(3.0 + p, -2.0 + y, 0.1 * p, fps))
    np.testing.assert_allclose(prof.mean, [3.0, -2.0, 0.0], atol=0.02)
    sd = np.sqrt((amps ** 2).sum() / 2)
    np.testing.assert_allclose(prof.sd, [sd, sd, 0.1 * sd], rtol=5e-3)
    # (end effects of the finite clip cost a few thousandths)
    np.testing.assert_allclose(prof.shares[0], amps ** 2 / (amps ** 2).sum(), atol=5e-3)
    np.testing.assert_allclose(prof.shares[1], amps[::-1] ** 2 / (amps ** 2).sum(), atol=5e-3)
    np.testing.assert_allclose(prof.shares.sum(axis=1), 1.0, atol=1e-9)
    assert set(prof.as_dict()["shares"]) == set(BAND_NAMES)


def test_apply_style_sines_takes_amplitudes_keeps_timing():
    """Candidate: four sines at 100 fps; reference at 30 fps with other amplitudes (and slightly
    other frequencies in the same bands).  The styled motion has the reference's band amplitudes,
    SD and mean, and the candidate's frequencies and phases."""
    fps_c, fps_r = 100.0, 30.0
    amp_c = np.array([1.0, 1.0, 1.0, 0.5])
    amp_r = np.array([4.0, 2.0, 0.5, 0.3])
    t, p = _sines(amp_c, fps_c, 40.0)
    _, pr = _sines(amp_r, fps_r, 60.0, phases=(0, 0, 0, 0), freqs=(0.3, 0.8, 2.2, 6.0))
    cand = _motion_deg(p, 0.5 * p, 0.2 * p, fps_c)
    ref = _motion_deg(-5.0 + pr, 2.0 + 0.5 * pr, 1.0 + 0.2 * pr, fps_r)
    out = apply_style(cand, ref)
    assert out.fps == fps_c and len(out) == len(cand)
    prof_o, prof_r = style_profile(out), style_profile(ref)
    np.testing.assert_allclose(prof_o.sd, prof_r.sd, rtol=1e-9)
    np.testing.assert_allclose(prof_o.mean, [-5.0, 2.0, 1.0], atol=0.02)
    np.testing.assert_allclose(prof_o.shares, prof_r.shares, atol=2e-3)
    pitch = out.as_pitch_yaw_roll(degrees=True)[:, 0]
    inner = slice(1000, -1000)  # away from the ends' filter transients
    for k, f in enumerate(F_BANDS):
        a_o, ph_o = _component(pitch[inner], t[inner], f)
        _, ph_c = _component(p[inner], t[inner], f)
        assert a_o == pytest.approx(amp_r[k], rel=0.03), (k, a_o)
        assert abs(np.angle(np.exp(1j * (ph_o - ph_c)))) < 0.01, k  # same phase: timing kept


def test_strength_and_match_mean():
    fps = 50.0
    _, p = _sines((1.0, 1.0, 1.0, 0.2), fps, 20.0)
    _, q = _sines((3.0, 0.5, 0.2, 0.05), fps, 20.0)
    cand = _motion_deg(1.0 + p, p, p, fps)
    ref = _motion_deg(-4.0 + q, 2 * q, q, fps)
    np.testing.assert_allclose(apply_style(cand, ref, strength=0.0).rotvec, cand.rotvec, atol=1e-9)
    half = style_profile(apply_style(cand, ref, strength=0.5))
    pc, pr = style_profile(cand), style_profile(ref)
    np.testing.assert_allclose(half.sd, np.sqrt(pc.sd * pr.sd), rtol=1e-6)
    np.testing.assert_allclose(half.mean, (pc.mean + pr.mean) / 2, atol=1e-6)
    kept = style_profile(apply_style(cand, ref, match_mean=False))
    np.testing.assert_allclose(kept.mean, pc.mean, atol=1e-6)
    np.testing.assert_allclose(kept.sd, pr.sd, rtol=1e-6)
    # a profile works as well as the motion it was measured on
    np.testing.assert_allclose(apply_style(cand, pr).rotvec, apply_style(cand, ref).rotvec, atol=1e-12)


def test_bad_input():
    fps = 25.0
    _, p = _sines((1, 1, 1, 1), fps, 10.0)
    m = _motion_deg(p, p, p, fps)
    with pytest.raises(ParameterError, match="at least 2 s"):
        apply_style(m, m.slice_frames(0, 25))
    with pytest.raises(ParameterError, match="strength"):
        apply_style(m, m, strength=1.5)
    with pytest.raises(ParameterError, match="Motion or StyleProfile"):
        apply_style(m, np.zeros((10, 3)))
    assert isinstance(style_profile(m), StyleProfile)


# ------------------------------------------------------------------------------------- real data
def _moved_half_way(before, after, ref):
    """Per axis: the styled figure is at most half as far from the reference as the unstyled one."""
    for ax in range(3):
        assert abs(after.sd[ax] - ref.sd[ax]) <= 0.5 * abs(before.sd[ax] - ref.sd[ax]) + 1e-9, ("sd", ax)
        d_after = np.abs(after.shares[ax] - ref.shares[ax]).sum()
        d_before = np.abs(before.shares[ax] - ref.shares[ax]).sum()
        assert d_after <= 0.5 * d_before + 1e-9, ("shares", ax, d_before, d_after)


@pytest.fixture(scope="module")
def default_model_output(shared_data):
    from headmotion.io.audio import load_audio
    from headmotion.systems.base import load_model

    model = load_model(ROOT / "src" / "headmotion" / "data" / "default_model.hmz")
    return model.predict(load_audio(shared_data / "speech" / "jfk.flac", sample_rate=model.sample_rate_))


@pytest.mark.parametrize("ref", ["zeggs", "dfrf_french", "sadtalker_WDA_KatieHill_000", "mimictalk_German_20s"])
def test_style_transfer_moves_half_way_on_real_recordings(shared_data, default_model_output, ref):
    if ref == "zeggs":
        path = shared_data / "mocap_speech" / "zeggs" / "067_Speech_2_x_1_0.bvh"
    else:
        path = CORPUS / f"{ref}.npz"
        if not path.exists():
            pytest.skip(f"the talking-video corpus is not built ({path} is absent)")
    reference = load_style_reference(path)
    styled = apply_style(default_model_output, reference)
    assert len(styled) == len(default_model_output) and styled.fps == default_model_output.fps
    before, after, target = (style_profile(m) for m in (default_model_output, styled, reference))
    _moved_half_way(before, after, target)
    np.testing.assert_allclose(after.mean, target.mean, atol=0.05)


@pytest.mark.slow
def test_style_reference_from_a_talking_video(shared_data, default_model_output):
    video = shared_data / "talking_video" / "pc_avs" / "Audio_Source_00086.mp4"
    reference = load_style_reference(video)
    assert reference.duration > 3.0 and reference.meta["source"] == str(video)
    styled = apply_style(default_model_output, reference)
    _moved_half_way(style_profile(default_model_output), style_profile(styled), style_profile(reference))


def test_a_still_candidate_stays_still_at_the_reference_pose():
    fps = 25.0
    _, q = _sines((3.0, 1.0, 0.5, 0.1), fps, 10.0)
    ref = _motion_deg(-4.0 + q, 2.0 + q, 1.0 + q, fps)
    out = apply_style(Motion(np.zeros((100, 3)), fps), ref)
    ang = out.as_pitch_yaw_roll(degrees=True)
    np.testing.assert_allclose(ang.std(axis=0), 0.0, atol=1e-9)
    np.testing.assert_allclose(ang[0], style_profile(ref).mean, atol=1e-9)
