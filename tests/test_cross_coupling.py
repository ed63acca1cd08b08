"""Cross-speaker coupling (headmotion.evaluation.measures.cross_coupling) and the reversal rate
(headmotion.evaluation.detection.detectability.reversal_rate): known answers."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import NotFittedError, ParameterError
from headmotion.evaluation.measures import cross_coupling as X
from headmotion.evaluation.detection.detectability import reversal_rate
from headmotion.types import FeatureTrack, Motion

FPS = 25.0


def _smooth(rng, T, D, width=15):
    k = np.hanning(width)
    k /= k.sum()
    x = rng.normal(size=(T + width, D))
    return np.stack([np.convolve(x[:, d], k, mode="valid")[:T] for d in range(D)], 1)


def _recording(rng, T=750, strength=1.0):
    """Speech features (T, 6) and a head (T, 3, radians) whose yaw follows the 'energy' column 3
    frames later (``strength`` 0: the head is a random walk uncoupled from the speech)."""
    f = _smooth(rng, T, 6, width=9)
    lagged = np.r_[np.full(3, f[0, 1]), f[:-3, 1]]
    walk = np.cumsum(rng.normal(scale=0.004, size=(T, 3)), axis=0)
    head = walk.copy()
    head[:, 1] += strength * 0.05 * lagged
    return head, f


@pytest.fixture(scope="module")
def fitted():
    rng = np.random.default_rng(5)
    train = [_recording(rng) for _ in range(8)]
    model = X.CrossSpeakerCCA().fit([m for m, _ in train], [f for _, f in train], fps=FPS)
    return model, rng


def test_speech_context_stacks_offsets():
    f = np.arange(10.0)[:, None] * np.array([[1.0, -1.0]])
    c = X.speech_context(f, 2)
    assert c.shape == (10, 10)
    # block k = −2 … 2 holds frame t + k, edges repeated
    assert c[5].tolist() == [3, -3, 4, -4, 5, -5, 6, -6, 7, -7]
    assert c[0, :2].tolist() == [0, 0] and c[9, -2:].tolist() == [9, -9]


def test_motion_descriptors_angles_and_speeds():
    t = np.arange(50) / FPS
    rv = np.radians(np.stack([t * 10.0, -t * 20.0, np.zeros_like(t)], 1))
    d = X.motion_descriptors(rv, FPS)
    np.testing.assert_allclose(d[:, :3], np.degrees(rv))
    np.testing.assert_allclose(d[:, 3:], np.tile([10.0, 20.0, 0.0], (50, 1)), atol=1e-9)


def test_planted_coupling_found_and_shifted_copy_and_other_recording_not(fitted):
    model, rng = fitted
    assert model.correlation_ > 0.4
    head, f = _recording(rng)
    r = model.test(head, f, fps=FPS, n_shifts=200, seed=1)
    assert r.statistic > 0.4 and r.excess > 0.3 and r.p_value < 0.05
    # the same motion circularly shifted by half its length: out of step with the speech
    s = model.test(np.roll(head, len(head) // 2, axis=0), f, fps=FPS, n_shifts=200, seed=1)
    assert abs(s.score) < 0.2 and s.p_value > 0.05
    # another recording's (coupled) motion against this recording's speech
    other, _ = _recording(rng)
    o = model.test(other, f, fps=FPS, n_shifts=200, seed=1)
    assert abs(o.score) < 0.2 and o.p_value > 0.05


def test_uncoupled_heads_pooled_p_is_not_small(fitted):
    model, rng = fitted
    res = []
    for i in range(12):
        head, f = _recording(rng, strength=0.0)
        res.append(model.test(head, f, fps=FPS, n_shifts=99, seed=i))
    pooled = X.pooled(res, n_shifts=99)
    assert pooled["n"] == 12 and pooled["p"] > 0.05 and abs(pooled["excess"]) < 0.1
    coupled = X.pooled([model.test(*_recording(rng), fps=FPS, n_shifts=99, seed=i) for i in range(4)], n_shifts=99)
    assert coupled["p"] < 1e-3 and coupled["excess"] > 0.3


def test_rates_and_types(fitted):
    model, rng = fitted
    head, f = _recording(rng)
    a = model.score(head, f, fps=FPS)
    # Motion / FeatureTrack carry their rate; 50 fps copies are resampled to 25 fps first
    b = model.score(Motion(head, FPS), FeatureTrack(f.astype(np.float32), FPS, tuple("abcdef")))
    assert b == pytest.approx(a, abs=1e-5)
    up = np.arange(2 * len(head) - 1) / 2.0
    h50 = np.stack([np.interp(up, np.arange(len(head)), head[:, j]) for j in range(3)], 1)
    f50 = np.stack([np.interp(up, np.arange(len(f)), f[:, j]) for j in range(6)], 1)
    assert model.score(h50, f50, fps=50.0) == pytest.approx(a, abs=1e-6)


def test_one_call_form():
    rng = np.random.default_rng(2)
    train = [_recording(rng) for _ in range(6)]
    test = [_recording(rng) for _ in range(3)]
    out = X.cross_speaker_coupling([m for m, _ in train], [f for _, f in train], [m for m, _ in test],
                                   [f for _, f in test], fps=FPS, test_fps=FPS, n_shifts=50, seed=0)
    assert out["n"] == 3 and len(out["per_recording"]) == 3 and out["p"] < 0.01


def test_bad_input():
    model = X.CrossSpeakerCCA()
    with pytest.raises(NotFittedError, match="not fitted"):
        model.score(np.zeros((10, 3)), np.zeros((10, 6)), fps=FPS)
    with pytest.raises(ParameterError, match="needs fps"):
        model.fit([np.zeros((10, 3))], [np.zeros((10, 6))])
    with pytest.raises(ParameterError, match="one feature track per motion"):
        model.fit([np.zeros((10, 3))], [], fps=FPS)
    with pytest.raises(ParameterError, match="'context' parameter"):
        X.CrossSpeakerCCA(context=-1).fit([np.zeros((10, 3))], [np.zeros((10, 6))], fps=FPS)


# -- reversal rate --------------------------------------------------------------------------------
def test_reversal_rate_of_a_sine_and_a_still_head():
    t = np.arange(0, 20, 1 / FPS)
    rv = np.radians(np.stack([5 * np.sin(2 * np.pi * 1.0 * t), 5 * np.sin(2 * np.pi * 0.5 * t), 0 * t], 1))
    r = reversal_rate(rv, fps=FPS)
    # a 1 Hz sine turns twice a second: 2 / 25 per frame; 0.5 Hz once; a still axis never
    np.testing.assert_allclose(r, [2 / 25, 1 / 25, 0.0], atol=0.003)
    assert reversal_rate(Motion(rv, FPS)).shape == (3,)


def test_reversal_rate_ignores_jitter_above_the_low_pass():
    fs = 100.0
    t = np.arange(0, 20, 1 / fs)
    clean = np.radians(np.stack([5 * np.sin(2 * np.pi * 0.7 * t)] * 3, 1))
    jitter = clean + np.radians(0.3) * np.sin(2 * np.pi * 20 * t)[:, None]
    assert reversal_rate(jitter, fps=fs)[0] > 0 and np.all(reversal_rate(jitter, fps=fs) < 0.07)
    np.testing.assert_allclose(reversal_rate(jitter, fps=fs), reversal_rate(clean, fps=fs), atol=0.002)
    # noise up to the 6 Hz cut-off reverses on a third of the frames; less with a 3 Hz low-pass
    white = np.random.default_rng(0).normal(size=(500, 3))
    assert np.all(reversal_rate(white, fps=FPS) > 0.3)
    assert np.all(reversal_rate(white, fps=FPS, cutoff_hz=3.0) < reversal_rate(white, fps=FPS))


# -- in headmotion evaluate -------------------------------------------------------------------------
def test_floor_rows_put_every_detectability_beside_the_floor():
    from headmotion.evaluation.detection.detectability import floor_rows

    rows = [{"system": s, "recording": "ALL", "metric": m, "value": v} for s, m, v in
            (("floor", "detect", 0.6), ("floor", "detect_3hz", 0.55), ("mine", "detect", 0.9),
             ("mine", "detect_3hz", 0.8), ("other", "detect", 0.7), ("mine", "fcca", 0.3))]
    out = {(r["system"], r["metric"]): r["value"] for r in floor_rows(rows)}
    assert out[("mine", "detect_floor")] == 0.6 and out[("mine", "detect_above_floor")] == pytest.approx(0.3)
    assert out[("mine", "detect_3hz_floor")] == 0.55 and out[("mine", "detect_3hz_above_floor")] == pytest.approx(0.25)
    assert out[("other", "detect_above_floor")] == pytest.approx(0.1) and ("other", "detect_3hz_floor") not in out
    assert out[("floor", "detect_above_floor")] == 0.0
    assert floor_rows([r for r in rows if r["system"] != "floor"]) == []  # no floor, no columns


def test_reversal_rows_pool_frames_over_recordings():
    from headmotion.evaluation.detection.detectability import reversal_rows

    t = np.arange(0, 20, 1 / FPS)
    one = np.radians(np.stack([5 * np.sin(2 * np.pi * t), 5 * np.sin(np.pi * t), 0 * t], 1))
    rows = reversal_rows({"gt": {"a": one, "b": one}, "still": {"a": 0 * one}}, FPS)
    v = {(r["system"], r["metric"]): r["value"] for r in rows}
    np.testing.assert_allclose([v[("gt", f"reversals_{ax}")] for ax in ("pitch", "yaw", "roll")],
                               reversal_rate(one, fps=FPS))
    assert v[("still", "reversals_yaw")] == 0.0


def test_low_pass_at_3_hz_removes_tremor_and_keeps_slow_motion():
    from headmotion.evaluation.detection.detectability import prepare

    t = np.arange(0, 20, 1 / FPS)
    slow = np.radians(np.stack([5 * np.sin(2 * np.pi * 1.0 * t)] * 3, 1))
    tremor = np.radians(np.stack([1 * np.sin(2 * np.pi * 6.0 * t)] * 3, 1))
    mid = slice(50, -50)
    assert np.ptp(prepare(tremor, FPS, cutoff_hz=3.0)[mid]) < np.ptp(np.degrees(tremor)) / 20
    np.testing.assert_allclose(np.ptp(prepare(slow, FPS, cutoff_hz=3.0)[mid], axis=0), 10.0, rtol=0.02)
    # at the default 6 Hz the tremor stays (half its amplitude at the cut-off, twice filtered)
    assert np.ptp(prepare(tremor, FPS)[mid]) > np.ptp(np.degrees(tremor)) / 5
    with pytest.raises(ParameterError, match="cutoff_hz"):
        prepare(slow, FPS, cutoff_hz=0)


def test_low_pass_detectability_rows():
    """Sines against white noise stay told apart at 3 Hz (the noise below 3 Hz is no sine); the rows
    carry the prefix ``detect_3hz`` and no per-statistic AUCs."""
    from headmotion.evaluation.detection.detectability import low_pass_rows

    rng = np.random.default_rng(0)
    t = np.arange(250) / FPS
    sines = {f"r{i}": np.radians(5 * np.sin(2 * np.pi * (0.3 + 0.05 * i) * t))[:, None] * np.ones(3)
             for i in range(10)}
    noise = {f"r{i}": np.radians(rng.normal(size=(250, 3))) for i in range(10)}
    rows = {r["metric"]: r["value"] for r in low_pass_rows(sines, {"noise": noise}, FPS, seed=0, n_boot=20,
                                                              classifiers=("stats",))}
    assert rows["detect_3hz"] > 0.9 and "detect_3hz_ba_stats_lo" in rows
    assert not any("stat_auc" in k for k in rows)


def test_cross_speaker_and_beat_alignment_measures_of_a_recording():
    """The per-recording measures ``headmotion evaluate`` runs: the planted coupled head is tied to
    the speech across speakers, its half-length shift is not; both get a beat-alignment test."""
    from types import SimpleNamespace

    from headmotion.evaluation.protocol import scoring as S

    rng = np.random.default_rng(5)
    train = [_recording(rng) for _ in range(8)]
    model = X.CrossSpeakerCCA().fit([m for m, _ in train], [f for _, f in train], fps=FPS)
    head, f = _recording(rng)
    rec = SimpleNamespace(id="r0", motion=Motion(head, FPS))
    cond = SimpleNamespace(name="c")
    onsets = np.arange(0.5, 29.0, 0.7)

    def scoring(pred):
        return S.RecordingScoring(condition=cond, recording=rec, pred=pred, features=FeatureTrack(
            f.astype(np.float32), FPS, tuple("abcdef")), seed=0, base_seed=0, window_s=3.0, n_shifts=100,
            context={"onsets": onsets}, coupling_model=model)

    ok = S.cross_speaker_coupling(scoring(head))
    assert ok["xcca_p"] < 0.05 and ok["xcca_excess"] > 0.3
    shifted = S.cross_speaker_coupling(scoring(np.roll(head, len(head) // 2, axis=0)))
    assert shifted["xcca_p"] > 0.05
    bc = S.beat_alignment(scoring(head))
    assert set(bc) == {"bc_null_mean", "bc_null_p95", "bc_p", "bc_excess"} and 0 < bc["bc_p"] <= 1
    assert S.cross_speaker_coupling(S.RecordingScoring(condition=cond, recording=rec, pred=head, features=f, seed=0,
                                                       base_seed=0, window_s=3.0, n_shifts=10)) == {}
    rows = [{"system": "c", "recording": f"r{i}", "metric": k, "value": v} for i in range(3)
            for k, v in {**ok, **bc}.items()]
    pooled = {r["metric"]: r["value"] for r in S.pooled_rows(rows, ["c"], n_shifts=100)}
    assert pooled["xcca_n_pooled"] == 3 and pooled["xcca_p_pooled"] < 0.01
    assert pooled["bc_excess_pooled"] == pytest.approx(bc["bc_excess"])
