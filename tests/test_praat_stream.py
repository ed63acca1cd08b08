"""Praat's pitch read on a stream in blocks (``f0e-live`` with ``reader="praat"``): known F0,
voicing as Praat's whole-file reading, interpolation across a gap, the same bits under any chunking,
bounded lookahead and memory, and clear errors."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.features import extract
from headmotion.features.praat_stream import StreamingPraatF0e
from headmotion.features.prosody import praat_pitch
from headmotion.features.readers import f0e_live, f0e_stream
from headmotion.types import Audio

SR = 16000
OFFLINE = dict(reader="praat", praat_block=250, praat_back_s=1.0, praat_ahead_s=1.0, interpolate=True)
LIVE = dict(reader="praat", praat_block=1, praat_back_s=0.3)


def _harmonic(f0: float, seconds: float = 2.0, amp: float = 0.3) -> np.ndarray:
    t = np.arange(int(seconds * SR)) / SR
    return sum(amp / k * np.sin(2 * np.pi * f0 * k * t) for k in range(1, 6)).astype(np.float32)


def _speechlike(rng, seconds: float = 6.0) -> np.ndarray:
    """Voiced syllables with a gliding F0 between pauses of noise: something to read both ways."""
    parts = []
    for _ in range(int(seconds / 0.6)):
        n = int(0.4 * SR)
        f = rng.uniform(90, 220) * np.exp(np.linspace(0, rng.uniform(-0.3, 0.3), n))
        ph = 2 * np.pi * np.cumsum(f) / SR
        parts.append(sum(0.3 / k * np.sin(k * ph) for k in range(1, 6)))
        parts.append(0.003 * rng.standard_normal(int(0.2 * SR)))
    return np.concatenate(parts).astype(np.float32)


def _streamed(x, sizes, **kw):
    ex = f0e_stream(sample_rate=SR, fps=25.0, voicing=True, **kw)
    out, i, k = [], 0, 0
    while i < len(x):
        n = sizes[k % len(sizes)]
        out.append(ex.push(x[i:i + n]))
        i, k = i + n, k + 1
    out.append(ex.flush())
    return np.vstack(out)


@pytest.mark.parametrize("params", [OFFLINE, LIVE], ids=["offline", "live"])
@pytest.mark.parametrize("f0", [110.0, 180.0, 260.0])
def test_harmonic_tone_gives_its_f0(params, f0):
    v, names = f0e_live(Audio(_harmonic(f0), SR), fps=25, n_frames=50, voicing=True, **params)
    assert names[-1] == "voiced"
    inner = slice(10, 40)
    np.testing.assert_allclose(np.exp(v[inner, 0]), f0, rtol=3e-3)
    assert v[inner, 6].min() == 1.0


@pytest.mark.parametrize("params", [OFFLINE, LIVE], ids=["offline", "live"])
def test_silence_is_unvoiced_and_holds_the_last_f0(params):
    x = np.concatenate([_harmonic(120.0, 1.0), np.zeros(2 * SR, np.float32)])
    v, _ = f0e_live(Audio(x, SR), fps=25, n_frames=75, voicing=True, smooth_frames=1, **params)
    assert v[35:, 6].max() == 0.0
    np.testing.assert_allclose(np.exp(v[35:, 0]), 120.0, rtol=3e-3)


def test_offline_interpolates_across_a_gap_the_live_reading_holds():
    x = np.concatenate([_harmonic(100.0, 1.0), np.zeros(SR // 2, np.float32), _harmonic(200.0, 1.0)])
    kw = dict(fps=25, n_frames=62, voicing=True, smooth_frames=1)
    off, _ = f0e_live(Audio(x, SR), **kw, **OFFLINE)
    live, _ = f0e_live(Audio(x, SR), **kw, **LIVE)
    gap = slice(27, 36)
    assert off[gap, 6].max() == 0.0 and live[gap, 6].max() == 0.0
    f_off = np.exp(off[gap, 0])
    assert np.all(np.diff(f_off) > 0) and 100 < f_off[0] < f_off[-1] < 200   # a glide from 100 to 200 Hz
    np.testing.assert_allclose(np.exp(live[gap, 0]), 100.0, rtol=3e-3)        # held


def test_blocks_read_voicing_as_praat_reads_the_whole_file(rng):
    x = _speechlike(rng, 12.0)
    n = int(len(x) / SR * 25)
    v, _ = f0e_live(Audio(x, SR), fps=25, n_frames=n, voicing=True, **OFFLINE)
    f0, voiced = praat_pitch(Audio(x, SR), fps=25, n_frames=n)
    assert np.mean((v[:, 6] > 0.5) == voiced) > 0.97
    assert 0.4 < voiced.mean() < 0.8


@pytest.mark.parametrize("params", [OFFLINE, LIVE], ids=["offline", "live"])
def test_streamed_equals_offline_exactly(params, rng):
    x = _speechlike(rng, 5.0)
    n = int(len(x) / SR * 25)
    whole = extract("f0e-live", Audio(x, SR), fps=25, n_frames=n, voicing=True, **params).values
    for sizes in ([160], [37, 1200, 5], [SR * 3]):
        s = _streamed(x, sizes, **params)[:n].astype(np.float32).astype(np.float64)
        np.testing.assert_array_equal(s, whole)


def test_live_frames_are_final_50_ms_after_their_start(rng):
    ex = f0e_stream(sample_rate=SR, fps=25.0, voicing=True, smooth_lookahead=0, delta_lookahead=0, **LIVE)
    assert ex.latency_ms == pytest.approx(50.0, abs=0.5)
    x = _speechlike(rng, 2.0)
    got = 0
    for i in range(0, len(x), 160):
        got += len(ex.push(x[i:i + 160]))
        in_s = (i + 160) / SR
        assert got >= int((in_s - ex.lookahead_s) * 25) - 1   # every frame final by its stated lookahead


def test_memory_stays_bounded_on_a_long_stream(rng):
    ex = StreamingPraatF0e(sample_rate=SR, fps=25.0, praat_block=250, praat_back_s=1.0, praat_ahead_s=1.0,
                           interpolate=True)
    chunk = (0.01 * rng.standard_normal(SR)).astype(np.float64)
    for _ in range(60):
        ex.push(chunk)
    assert len(ex._buf) < 20 * SR            # one block's read, not the minute pushed
    assert ex._static.n < 600                 # and not every frame of it


def test_bad_settings_are_refused():
    with pytest.raises(ParameterError, match="reader"):
        f0e_stream(reader="crepe", sample_rate=SR, fps=25.0)
    with pytest.raises(ParameterError, match="praat_block"):
        StreamingPraatF0e(sample_rate=SR, fps=25.0, praat_block=0)
    with pytest.raises(ParameterError, match="praat_back_s"):
        StreamingPraatF0e(sample_rate=SR, fps=25.0, praat_back_s=-1.0)
