"""Incremental F0 + energy features: known F0, streamed == offline exactly,
bounded lookahead, and agreement with the offline Praat-based ``f0e`` on real speech."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.features import extract
from headmotion.features.streaming import StreamingF0e, f0e_live, regression_weights
from headmotion.types import Audio

SR = 16000


def _harmonic(f0: float, seconds: float = 2.0, amp: float = 0.3) -> np.ndarray:
    t = np.arange(int(seconds * SR)) / SR
    return sum(amp / k * np.sin(2 * np.pi * f0 * k * t) for k in range(1, 6)).astype(np.float32)


@pytest.mark.parametrize("f0", [100.0, 150.0, 230.0])
def test_harmonic_tone_gives_its_f0(f0):
    v, names = f0e_live(Audio(_harmonic(f0), SR), fps=100, n_frames=200, voicing=True)
    assert names[:2] == ["logf0", "energy"] and names[-1] == "voiced"
    inner = slice(20, 180)  # past the start-up transient of smoothing and deltas
    np.testing.assert_allclose(np.exp(v[inner, 0]), f0, rtol=2e-3)
    assert v[inner, 6].min() == 1.0
    np.testing.assert_allclose(v[inner, 2:6], 0.0, atol=1e-9)  # a steady tone: zero Δ, ΔΔ


def test_energy_of_a_sine_is_its_power_in_db():
    t = np.arange(SR) / SR
    x = (0.5 * np.sin(2 * np.pi * 200 * t)).astype(np.float32)
    v, _ = f0e_live(Audio(x, SR), fps=100, n_frames=100)
    np.testing.assert_allclose(v[20:80, 1], 10 * np.log10(0.125), atol=0.05)


def test_regression_weights_are_htk_deltas_when_centred():
    w = regression_weights(5, 2)
    np.testing.assert_allclose(w, np.array([-2, -1, 0, 1, 2]) / 10.0)
    ramp = np.arange(5.0)
    for la in range(5):
        assert regression_weights(5, la) @ ramp == pytest.approx(1.0)


def test_unvoiced_holds_last_voiced_f0():
    x = np.concatenate([_harmonic(120.0, 1.0), np.zeros(SR, np.float32)])
    v, _ = f0e_live(Audio(x, SR), fps=100, n_frames=200, voicing=True, smooth_frames=1)
    assert v[150:, 6].max() == 0.0
    np.testing.assert_allclose(np.exp(v[150:, 0]), 120.0, rtol=2e-3)


def _stream(x, sizes, **kw):
    ex = StreamingF0e(**kw)
    out, i, k = [], 0, 0
    while i < len(x):
        n = sizes[k % len(sizes)]
        out.append(ex.push(x[i:i + n]))
        i += n
        k += 1
    out.append(ex.flush())
    return np.vstack(out), ex


@pytest.mark.shared
def test_streamed_equals_offline_exactly_on_real_speech(shared_data):
    from headmotion.io import load_audio

    a = load_audio(shared_data / "speech" / "jfk.flac", sample_rate=SR)
    x = a.samples[: 6 * SR]
    off = extract("f0e-live", Audio(x, SR)).values
    for sizes in ([160], [1], [37, 1000, 3, 480], [len(x)]):
        got, _ = _stream(x, sizes)
        assert got.shape == off.shape
        assert np.array_equal(got.astype(np.float32), off), sizes
    # and in float64, chunkings agree bit for bit
    a1, _ = _stream(x, [160])
    a2, _ = _stream(x, [7, 333])
    assert np.array_equal(a1, a2)


def test_frames_are_final_within_the_stated_lookahead(rng):
    x = (0.1 * rng.standard_normal(3 * SR)).astype(np.float32)
    ex = StreamingF0e()
    assert ex.latency_ms <= 65.0
    la = int(round(ex.lookahead_s * SR))  # samples needed beyond a frame's start
    n_out = 0
    for i in range(0, len(x), 160):
        n_out += len(ex.push(x[i:i + 160]))
        have = i + 160
        # frame t is emitted exactly when sample t * 160 + la is in: no later, no earlier
        assert n_out == max(0, (have - la) // 160 + 1), (have, n_out)


def test_memory_stays_bounded_on_minutes_of_silence():
    ex = StreamingF0e()
    z = np.zeros(SR, np.float32)
    n = 0
    for _ in range(180):  # three minutes, pushed a second at a time
        n += len(ex.push(z))
    n += len(ex.flush())
    assert n == 18000
    assert len(ex._buf) < 4 * SR and len(ex._static.arr) < 400


def test_bad_input():
    ex = StreamingF0e()
    with pytest.raises(ParameterError, match="NaN"):
        ex.push(np.array([0.0, np.nan]))
    ex.flush()
    with pytest.raises(ParameterError, match="after flush"):
        ex.push(np.zeros(10))
    with pytest.raises(ParameterError):
        StreamingF0e(delta_width=4)
    with pytest.raises(ParameterError):
        StreamingF0e(pitch_floor=300, pitch_ceiling=100)


@pytest.mark.shared
def test_f0_agrees_with_praat_on_voiced_frames(shared_data):
    from headmotion.features.prosody import praat_pitch
    from headmotion.io import load_audio

    a = load_audio(shared_data / "speech" / "RD_Radio34_002.wav", sample_rate=SR)
    A = Audio(a.samples[: 20 * SR], SR)
    T = len(A.samples) // 160
    v, _ = f0e_live(A, fps=100, n_frames=T, smooth_frames=1, voicing=True)
    f0, pv = praat_pitch(A, fps=100, n_frames=T, pitch_step=0.01)
    both = (v[:, 6] > 0) & pv
    assert both.mean() > 0.3
    assert np.corrcoef(v[both, 0], np.log(f0[both]))[0, 1] > 0.95
    semis = 12 * np.abs(v[both, 0] - np.log(f0[both])) / np.log(2)
    assert np.median(semis) < 0.2


@pytest.mark.parametrize("fps", [25.0, 29.97, 60.0])
def test_streamed_equals_offline_at_other_frame_rates(fps, rng):
    x = np.concatenate([_harmonic(180.0, 1.0), (0.05 * rng.standard_normal(SR)).astype(np.float32)])
    off, _ = f0e_live(Audio(x, SR), fps=fps, n_frames=int(np.floor(len(x) * fps / SR + 0.5)))
    got, ex = _stream(x, [160, 7, 999], fps=fps)
    assert np.array_equal(got, off)
    assert ex.latency_ms <= 100 + 1000 * 2.5 / fps   # the lookahead is in frames: longer at low rates
    np.testing.assert_allclose(np.exp(off[int(0.3 * fps):int(0.7 * fps), 0]), 180.0, rtol=2e-3)


# -- prosody-live (the Le et al. baseline's pitch + loudness) ---------------------------------------
def test_prosody_live_known_pitch_and_loudness():
    from headmotion.features.streaming import StreamingProsody

    t = np.arange(SR) / SR
    x = (0.5 * np.sin(2 * np.pi * 220 * t)).astype(np.float32)
    tr = extract("prosody-live", Audio(x, SR))
    assert tr.names == ("pitch", "loudness")
    np.testing.assert_allclose(tr.values[10:90, 0], 12 * np.log2(220 / 27.5), atol=0.01)   # 36 semitones
    np.testing.assert_allclose(tr.values[10:90, 1], (0.125 / 1e-6) ** 0.3, rtol=1e-4)      # (I / I0)^0.3
    hz = extract("prosody-live", Audio(x, SR), unit="hz").values
    np.testing.assert_allclose(hz[10:90, 0], 220.0, rtol=1e-3)
    # the same loudness as the offline openSMILE-like definition, frame for frame
    np.testing.assert_allclose(tr.values[:, 1], extract("prosody", Audio(x, SR)).values[:, 1], rtol=1e-5)
    ex = StreamingProsody()
    assert ex.latency_ms < 25.0
    with pytest.raises(ParameterError, match="no smoothing"):
        StreamingProsody(smooth_frames=10)


def test_prosody_live_streamed_equals_offline(rng):
    from headmotion.features.streaming import StreamingProsody

    x = np.concatenate([_harmonic(130.0, 1.0), (0.05 * rng.standard_normal(SR)).astype(np.float32)])
    off = extract("prosody-live", Audio(x, SR)).values
    ex = StreamingProsody()
    la = int(round(ex.lookahead_s * SR))
    out = []
    for i in range(0, len(x), 160):
        out.append(ex.push(x[i:i + 160]))
        assert sum(len(o) for o in out) == max(0, (i + 160 - la) // 160 + 1)
    out.append(ex.flush())
    assert np.array_equal(np.vstack(out).astype(np.float32), off)
