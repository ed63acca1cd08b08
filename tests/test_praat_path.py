"""Praat's candidates read frame by frame with its path searched forward (``f0e-live`` with
``reader="praat-path"``): the path search reproduces Praat's own path on a whole read, windows
read together get what they get alone, the local peak is Praat's, known F0, silence, the same bits
under any chunking, the latency it states, bounded memory, clear errors."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.features import extract
from headmotion.features.praat_path import (
    BLOCK,
    MAX_CANDIDATES,
    PRAAT_SILENCE,
    PRAAT_VOICING,
    PraatPathF0e,
    local_peaks,
    local_strengths,
    path_scores,
    praat_candidates,
    transition_costs,
)
from headmotion.features.readers import f0e_live, f0e_stream
from headmotion.types import Audio

SR = 16000
PATH = dict(reader="praat-path")


def _harmonic(f0: float, seconds: float = 2.0, amp: float = 0.3) -> np.ndarray:
    t = np.arange(int(seconds * SR)) / SR
    return sum(amp / k * np.sin(2 * np.pi * f0 * k * t) for k in range(1, 6)).astype(np.float32)


def _speechlike(rng, seconds: float = 6.0) -> np.ndarray:
    """Voiced syllables with a gliding F0 between quiet noise, louder and softer."""
    parts = []
    for _ in range(int(seconds / 0.6)):
        n = int(0.4 * SR)
        f = rng.uniform(90, 220) * np.exp(np.linspace(0, rng.uniform(-0.3, 0.3), n))
        ph = 2 * np.pi * np.cumsum(f) / SR
        amp = rng.uniform(0.05, 0.4)
        parts.append(sum(amp / k * np.sin(k * ph) for k in range(1, 6)) + 0.01 * rng.standard_normal(n))
        parts.append(0.003 * rng.standard_normal(int(0.2 * SR)))
    return np.concatenate(parts).astype(np.float32)


def _viterbi(freq, strength, intensity, step, ceiling):
    """The whole-read path from :func:`path_scores` with its backtrace."""
    scores, backs, cands = None, [], []
    for t in range(freq.shape[0]):
        ok = ~np.isnan(freq[t])
        local, voiced = local_strengths(freq[t][ok], strength[t][ok], intensity[t], ceiling=ceiling)
        log2 = np.log2(np.where(voiced, freq[t][ok], 1.0))
        costs = None if scores is None else transition_costs(cands[-1][1], cands[-1][2], log2, voiced, step=step)
        scores, back = path_scores(scores, costs, local)
        backs.append(back)
        cands.append((freq[t][ok], log2, voiced))
    k = int(np.argmax(scores))
    out = np.zeros(freq.shape[0])
    for t in range(freq.shape[0] - 1, -1, -1):
        f, _, voiced = cands[t]
        out[t] = f[k] if voiced[k] else 0.0
        k = int(backs[t][k])
    return out


@pytest.mark.parametrize("step", [0.01, 0.02])
def test_the_path_search_is_praats_own_on_a_whole_read(rng, step):
    import parselmouth

    x = _speechlike(rng, 8.0).astype(np.float64)
    pitch = parselmouth.Sound(x, sampling_frequency=float(SR)).to_pitch_ac(
        time_step=step, pitch_floor=75.0, pitch_ceiling=600.0, max_number_of_candidates=MAX_CANDIDATES,
        silence_threshold=PRAAT_SILENCE, voicing_threshold=PRAAT_VOICING)
    arr = pitch.to_array()
    intensity = np.array([pitch.get_frame(i + 1).intensity for i in range(pitch.n_frames)])
    ours = _viterbi(arr["frequency"].T, arr["strength"].T, intensity, step, 600.0)
    praat = pitch.selected_array["frequency"]
    assert 0.3 < np.mean(praat > 0) < 0.9
    np.testing.assert_array_equal(ours, praat)


@pytest.mark.parametrize("f0", [110.0, 180.0, 260.0])
def test_harmonic_tone_gives_its_f0(f0):
    v, names = f0e_live(Audio(_harmonic(f0), SR), fps=25, n_frames=50, voicing=True, **PATH)
    assert names[-1] == "voiced"
    inner = slice(10, 40)
    np.testing.assert_allclose(np.exp(v[inner, 0]), f0, rtol=3e-3)
    assert v[inner, 6].min() == 1.0


def test_silence_is_unvoiced_and_holds_the_last_f0():
    x = np.concatenate([_harmonic(120.0, 1.0), np.zeros(2 * SR, np.float32)])
    v, _ = f0e_live(Audio(x, SR), fps=25, n_frames=75, voicing=True, smooth_frames=1, **PATH)
    assert v[35:, 6].max() == 0.0
    np.testing.assert_allclose(np.exp(v[35:, 0]), 120.0, rtol=3e-3)


def test_quiet_noise_after_loud_speech_is_unvoiced_by_the_running_peak(rng):
    """Noise far below the voice heard so far is silence to the path (Praat's silence cost against
    the running peak), though a read of that noise alone could find a period in it."""
    noise = (0.002 * rng.standard_normal(SR)).astype(np.float32)
    x = np.concatenate([_harmonic(150.0, 1.0, amp=0.5), noise])
    v, _ = f0e_live(Audio(x, SR), fps=25, n_frames=50, voicing=True, smooth_frames=1, **PATH)
    assert v[5:24, 6].min() == 1.0 and v[28:, 6].max() == 0.0


def test_voicing_is_close_to_praats_on_the_whole_file(rng):
    from headmotion.features.prosody import praat_pitch

    x = _speechlike(rng, 12.0)
    n = int(len(x) / SR * 25)
    v, _ = f0e_live(Audio(x, SR), fps=25, n_frames=n, voicing=True, **PATH)
    _, voiced = praat_pitch(Audio(x, SR), fps=25, n_frames=n)
    assert np.mean((v[:, 6] > 0.5) == voiced) > 0.93


def test_windows_read_together_get_the_candidates_they_get_alone(rng):
    """One Praat call for many windows (a stream's frames, or other streams') gives each window the
    candidates and local peak of a read of it alone, bit for bit; a silent window has only the
    unvoiced candidate."""
    x = _speechlike(rng, 3.0).astype(np.float64)
    wins = np.stack([x[s:s + 640] for s in range(0, len(x) - 640, 333)])
    wins[::2] *= 0.02   # quiet beside loud: Praat's own path (which orders its candidates) differs
    wins[3] = 0.0
    freq, strength, peaks = praat_candidates(wins, SR, floor=75.0, ceiling=600.0)
    assert freq.shape[0] == len(wins) and np.count_nonzero(~np.isnan(freq[3])) == 1 and freq[3, 0] == 0.0
    assert peaks[3] == 0.0 and (peaks[np.arange(len(wins)) != 3] > 0).all()
    for k in range(len(wins)):
        f, s, p = praat_candidates(wins[k:k + 1], SR, floor=75.0, ceiling=600.0)
        ok, ok_k = ~np.isnan(f[0]), ~np.isnan(freq[k])
        np.testing.assert_array_equal(f[0][ok], freq[k][ok_k])
        np.testing.assert_array_equal(s[0][ok], strength[k][ok_k])
        assert p[0] == peaks[k]


def test_local_peak_is_praats(rng):
    """The local peak is Praat's: a read of the window alone reports it as its intensity (the
    local peak over the window's peak about its mean)."""
    import parselmouth

    x = _speechlike(rng, 2.0).astype(np.float64)
    wins = np.stack([x[s:s + 640] for s in range(0, len(x) - 640, 997)])
    ours = local_peaks(wins, SR, floor=75.0)
    for w, p in zip(wins, ours):
        pitch = parselmouth.Sound(w, sampling_frequency=float(SR)).to_pitch_ac(time_step=0.02, pitch_floor=75.0,
                                                                               pitch_ceiling=600.0)
        praat = pitch.get_frame(1).intensity * np.abs(w - w.mean()).max()
        assert p == pytest.approx(praat, rel=1e-9)


def test_streamed_equals_offline_exactly(rng):
    x = _speechlike(rng, 2 * BLOCK * 0.02 + 1.0)   # offline, read in more than one block
    n = int(len(x) / SR * 25)
    whole = extract("f0e-live", Audio(x, SR), fps=25, n_frames=n, voicing=True, **PATH).values
    for sizes in ([160], [37, 1200, 5], [SR * 3]):
        ex = f0e_stream(sample_rate=SR, fps=25.0, voicing=True, **PATH)
        out, i, k = [], 0, 0
        while i < len(x):
            out.append(ex.push(x[i:i + sizes[k % len(sizes)]]))
            i, k = i + sizes[k % len(sizes)], k + 1
        out.append(ex.flush())
        s = np.vstack(out)[:n].astype(np.float32).astype(np.float64)
        np.testing.assert_array_equal(s, whole)


def test_frames_are_final_40_ms_after_their_start(rng):
    ex = f0e_stream(sample_rate=SR, fps=25.0, voicing=True, smooth_lookahead=0, delta_lookahead=0, **PATH)
    assert ex.latency_ms == pytest.approx(40.0, abs=0.5)
    x = _speechlike(rng, 2.0)
    got = 0
    for i in range(0, len(x), 160):
        got += len(ex.push(x[i:i + 160]))
        assert got >= int(((i + 160) / SR - ex.lookahead_s) * 25) - 1   # every frame final by its stated lookahead


def test_memory_stays_bounded_on_a_long_stream(rng):
    ex = PraatPathF0e(sample_rate=SR, fps=25.0)
    chunk = (0.01 * rng.standard_normal(SR)).astype(np.float64)
    for _ in range(60):
        ex.push(chunk)
    assert len(ex._buf) < SR and ex._static.n < 300   # not the 1500 frames pushed


@pytest.mark.parametrize("sr", [8000, 22050, 44100])
def test_other_sample_rates_read_the_tone(sr):
    t = np.arange(2 * sr) / sr
    x = sum(0.3 / k * np.sin(2 * np.pi * 140.0 * k * t) for k in range(1, 4))
    v, _ = f0e_live(Audio(x.astype(np.float32), sr), fps=25, n_frames=50, voicing=True, **PATH)
    np.testing.assert_allclose(np.exp(v[10:40, 0]), 140.0, rtol=3e-3)


def test_bad_settings_are_refused():
    with pytest.raises(ParameterError, match="praat_step"):
        PraatPathF0e(sample_rate=SR, fps=25.0, praat_step=0.0)
    with pytest.raises(ParameterError, match="peak_half_life_s"):
        PraatPathF0e(sample_rate=SR, fps=25.0, peak_half_life_s=0.0)
    with pytest.raises(ParameterError, match="octave_jump_cost"):
        PraatPathF0e(sample_rate=SR, fps=25.0, octave_jump_cost=-1.0)
