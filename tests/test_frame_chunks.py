"""features/frames.py: windows a chunk at a time are the rows of the whole framing (bounded memory
for long recordings), and the chunked mel analysis gives the whole-signal values (to float64
rounding)."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.features import frames, spectral
from headmotion.types import Audio


@pytest.mark.parametrize("n, fps, n_frames, win, chunk", [(16000, 100.0, 100, 400, 7), (16000, 29.97, 30, 401, 4),
                                                         (150, 100.0, 5, 400, 2), (16000, 100.0, 130, 400, 4096),
                                                         (0, 100.0, 3, 400, 2)])
def test_frame_chunks_are_the_rows_of_frame_signal(n, fps, n_frames, win, chunk):
    x = np.random.default_rng(0).standard_normal(n).astype(np.float32)
    whole = frames.frame_signal(x, sample_rate=16000, fps=fps, n_frames=n_frames, win_length=win)
    parts = list(frames.frame_chunks(x, sample_rate=16000, fps=fps, n_frames=n_frames, win_length=win, chunk=chunk))
    assert [a for a, _ in parts] == list(range(0, n_frames, chunk))
    np.testing.assert_array_equal(np.concatenate([p for _, p in parts]), whole)
    assert whole.shape == (n_frames, win)
    e = frames.frame_log_energy_db(x, sample_rate=16000, fps=fps, n_frames=n_frames, win_length=win)
    np.testing.assert_array_equal(e, frames.log_energy_db(whole))


def test_frame_signal_zero_pads_outside_the_signal():
    x = np.arange(1, 11, dtype=np.float32)
    f = frames.frame_signal(x, sample_rate=10, fps=2.0, n_frames=2, win_length=4)
    # centres at samples 2.5 and 7.5: windows start at 1 and 6
    np.testing.assert_array_equal(f, [[2, 3, 4, 5], [7, 8, 9, 10]])
    # centres at samples 5 and 15: the second window starts past the end and is all zeros
    g = frames.frame_signal(x, sample_rate=10, fps=1.0, n_frames=2, win_length=8)
    np.testing.assert_array_equal(g, [[2, 3, 4, 5, 6, 7, 8, 9], [0] * 8])
    parts = [p for _, p in frames.frame_chunks(x, sample_rate=10, fps=1.0, n_frames=2, win_length=8, chunk=1)]
    np.testing.assert_array_equal(np.concatenate(parts), g)


def test_chunked_mfcc_equals_the_whole_signal_analysis(monkeypatch):
    rng = np.random.default_rng(1)
    a = Audio((0.1 * rng.standard_normal(16000 * 3)).astype(np.float32), 16000)
    whole, _ = spectral.mfcc(a, fps=100.0, n_frames=300)
    monkeypatch.setitem(frames.frame_chunks.__kwdefaults__, "chunk", 37)   # 300 frames in 9 chunks
    chunked, _ = spectral.mfcc(a, fps=100.0, n_frames=300)
    # the mel matrix product of 37 rows may round differently from that of 300 (BLAS blocking)
    np.testing.assert_allclose(chunked, whole, rtol=1e-9, atol=1e-12)
    power, _ = spectral.mel_power(a, fps=100.0, n_frames=300)
    logmel = np.log(np.maximum(power, spectral.LOG_FLOOR))
    fb, _ = spectral.fbank(a, fps=100.0, n_frames=300)
    np.testing.assert_allclose(fb[:, :-1], logmel, rtol=1e-9, atol=1e-12)
