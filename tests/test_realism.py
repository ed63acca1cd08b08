"""Known-answer tests of the realism measures."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.evaluation.measures import realism as R
from headmotion.types import Motion

FPS = 30.0
RAD = np.pi / 180


def sine(freq, seconds=60.0, amp_deg=3.0, fps=FPS, axes=3):
    t = np.arange(int(seconds * fps)) / fps
    x = np.zeros((len(t), 3))
    for j in range(axes):
        x[:, j] = amp_deg * RAD * np.sin(2 * np.pi * freq * t + j)
    return Motion(x, fps)


def test_sinusoid_band_share_is_one():
    s = R.band_shares(sine(1.0))
    assert s[1] == pytest.approx(1.0, abs=0.02)
    s = R.band_shares(sine(2.5))
    assert s[2] == pytest.approx(1.0, abs=0.02)
    assert R.spectral_distance(R.band_shares(sine(1.0)), R.band_shares(sine(2.5))) == pytest.approx(2.0, abs=0.05)


def test_pooled_spectral_distance_compares_the_sets_mean_shares():
    slow, mid = sine(0.25), sine(1.0)
    assert R.pooled_spectral_distance([slow, mid], [mid, slow]) == pytest.approx(0.0, abs=1e-12)
    assert R.pooled_spectral_distance([slow], [mid]) == pytest.approx(2.0, abs=0.05)
    # half the set moved from the slow band to the mid band: L1 = 2 x 0.5
    assert R.pooled_spectral_distance([slow, slow], [slow, mid]) == pytest.approx(1.0, abs=0.03)
    # amplitude does not weigh: a recording 10x louder counts as one recording
    loud = sine(1.0, amp_deg=30.0)
    assert R.pooled_spectral_distance([slow, slow], [slow, loud]) == pytest.approx(1.0, abs=0.03)
    with pytest.raises(ParameterError):
        R.pooled_spectral_distance([], [slow])


def test_realism_rows_summary_has_the_pooled_spectral_distance():
    slow, mid = sine(0.25, seconds=20), sine(1.0, seconds=20)
    rows = R.realism_rows({"same": [slow, mid], "swapped": [mid, slow]}, [slow, mid])
    summ = {r["condition"]: r for r in rows if r["recording"] == "ALL"}
    assert summ["same"]["spectral_l1_pooled"] == pytest.approx(0.0, abs=1e-12)
    # every recording is wrong (per-recording L1 ≈ 2), the set's shares are right
    assert summ["swapped"]["spectral_l1"] == pytest.approx(2.0, abs=0.1)
    assert summ["swapped"]["spectral_l1_pooled"] == pytest.approx(0.0, abs=0.05)


def test_still_motion_has_no_shares():
    assert np.all(R.band_shares(Motion(np.zeros((300, 3)), FPS)) == 0)


def test_limit_cycle_sinusoid_vs_white_noise(rng):
    lc, per = R.limit_cycle_index(sine(1.0))
    assert lc == pytest.approx(1.0, abs=0.03) and np.all(per > 0.95)
    noise = Motion(np.cumsum(rng.standard_normal((3000, 3)) * 0.001, axis=0), FPS)  # white velocity
    assert R.limit_cycle_index(noise)[0] < 0.1


def test_hellinger_identical_and_disjoint():
    p = np.array([0.2, 0.3, 0.5, 0.0])
    assert R.hellinger(p, p) == 0.0
    assert R.hellinger([1, 0], [0, 1]) == pytest.approx(1.0)
    with pytest.raises(ParameterError):
        R.hellinger([1, 0], [1, 0, 0])


def test_speed_of_constant_rotation():
    t = np.arange(100) / FPS
    x = np.zeros((100, 3))
    x[:, 1] = 10 * RAD * t  # 10 deg/s of yaw
    assert np.allclose(R.speed(Motion(x, FPS)), 10.0)
    assert np.allclose(R.acceleration(Motion(x, FPS)), 0.0, atol=1e-9)


def test_sd_ratio_and_drift():
    a = sine(1.0)
    assert np.allclose(R.sd_ratio(a.rotvec, a.rotvec * 2), 2.0)
    # a 1 Hz sinusoid averages out over 5 s; a slow ramp does not
    assert np.all(R.drift(a) < 0.05)
    ramp = np.zeros((1800, 3))
    ramp[:, 0] = np.linspace(0, 10 * RAD, 1800)
    d = R.drift(Motion(ramp, FPS))
    assert d[0] > 2.0 and d[1] == 0.0


def test_saturation():
    x = np.zeros((100, 3))
    x[:10, 1] = 39.5 * RAD
    lim = np.array([[-40, 40]] * 3, float)
    assert R.saturation(Motion(x, FPS), lim) == pytest.approx(0.10)


def test_pause_speed_ratio():
    x = np.zeros((300, 3))
    t = np.arange(300) / FPS
    x[:, 0] = 2 * RAD * np.sin(2 * np.pi * t)
    mask = np.ones(300, bool)
    mask[100:200] = False  # a 3.3 s pause
    x[100:200, 0] = x[100, 0] + 0.5 * (x[100:200, 0] - x[100, 0])  # half the swing there
    r = R.pause_speed_ratio(Motion(x, FPS), mask)
    assert 0.4 < r < 0.6
    # pauses shorter than 0.5 s do not count
    short = np.ones(300, bool)
    short[50:55] = False
    assert np.isnan(R.pause_speed_ratio(Motion(x, FPS), short))


def test_diversity():
    a = sine(1.0).rotvec
    assert R.diversity([a, a, a], a) == 0.0
    b = a + np.array([1.0, 0, 0]) * a[:, :1].std() * 0  # identical
    assert R.diversity([a, b], a) == 0.0
    shifted = a + 0.1
    assert R.diversity([a, shifted], a) == pytest.approx(0.1 * np.sqrt(3) / np.sqrt(a.var(axis=0).sum()))


def test_beat_consistency_known_onsets():
    # speed minima exactly at the onsets: |sin| speed has minima at multiples of the half period
    t = np.arange(int(20 * FPS)) / FPS
    x = np.zeros((len(t), 3))
    x[:, 0] = -np.cos(2 * np.pi * 0.5 * t) * 5 * RAD  # velocity ∝ sin(π t): speed minima at t = 0, 1, 2, ...
    beats = R.motion_beats(Motion(x, FPS))
    onsets = np.arange(2, 18, 2.0)
    assert np.min(np.abs(beats[:, None] - onsets[None]), axis=0).max() <= 1 / FPS + 1e-9
    assert R.beat_consistency(beats, onsets) > 0.99
    assert R.beat_consistency(onsets, onsets) == 1.0
    assert R.beat_consistency(onsets + 1.0, onsets) < 0.01


def test_stouffer():
    assert R.stouffer([0.5, 0.5, 0.5]) == pytest.approx(0.5)
    assert R.stouffer([0.01] * 4) < 0.01
    assert R.stouffer([0.9] * 4) > 0.9


def test_stouffer_of_circular_shift_p_values_uses_mid_p():
    from scipy.stats import norm

    n = 100
    best, worst = 1 / (n + 1), 1.0  # every shift below the score / every shift above it
    # the best and the worst possible recordings cancel
    assert R.stouffer([best, worst], n_shifts=n) == pytest.approx(0.5, abs=1e-12)
    z1 = norm.isf(0.5 / (n + 1))
    assert R.stouffer([best] * 4, n_shifts=n) == pytest.approx(norm.sf(4 * z1 / 2), rel=1e-9)
    # three perfectly coupled recordings and one at the bottom: z = 2 z1 / 2 (the clipped p = 1
    # used to weigh −7 and hide the three)
    assert R.stouffer([best] * 3 + [worst], n_shifts=n) == pytest.approx(norm.sf(z1), rel=1e-9)
    assert R.stouffer([best] * 3 + [worst]) > 0.4
    # a uniform spread of shift p-values is no evidence either way
    ks = np.arange(n + 1)
    assert R.stouffer((1 + ks) / (n + 1), n_shifts=n) == pytest.approx(0.5, abs=1e-9)


def test_realism_row_and_rows(rng):
    ref = sine(0.3, seconds=30)
    cand = sine(2.0, seconds=30)
    feats = ref.rotvec[:, :2] + 0.01 * rng.standard_normal((len(ref), 2))
    row = R.realism(ref, ref, features=feats, n_shifts=50)
    assert row["spectral_l1"] == 0.0 and row["speed_hellinger"] == 0.0
    assert row["fcca_excess"] > 0.3 and row["fcca_p"] < 0.05
    rows = R.realism_rows({"gt": [ref, ref], "bob": [cand, cand]}, [ref, ref], features=[feats, feats],
                          limits_deg={"bob": np.array([[-40, 40]] * 3, float)}, n_shifts=50)
    assert len(rows) == 6
    summ = {r["condition"]: r for r in rows if r["recording"] == "ALL"}
    assert summ["bob"]["band_1.5_4"] > 0.95 and summ["gt"]["band_0_0.5"] > 0.95
    assert summ["bob"]["spectral_l1"] > 1.8
    assert summ["gt"]["fcca_p_pooled"] < 0.01
    assert summ["bob"]["saturation"] == 0.0


def test_figures(tmp_path):
    from headmotion.evaluation.reporting import realism_figures as RF

    conds = {"ground-truth": [sine(0.3, seconds=30)], "bob": [sine(2.5, seconds=30)]}
    p = RF.mean_psd(conds["bob"])
    assert abs(RF.GRID[np.argmax(p[:, 0])] - 2.5) <= 0.1
    RF.spectra_figure(conds, path=tmp_path / "s.png")
    RF.speed_histogram_figure(conds, path=tmp_path / "h.png")
    rows = R.realism_rows({"gt": [conds["ground-truth"][0]], "bob": conds["bob"]}, conds["ground-truth"],
                          features=[conds["ground-truth"][0].rotvec[:, :2]], n_shifts=20)
    RF.realism_coupling_scatter(rows, path=tmp_path / "c.png")
    for f in ("s.png", "h.png", "c.png"):
        assert (tmp_path / f).read_bytes()[:4] == b"\x89PNG"


def test_real_zeggs_take_measures(shared_data):
    from headmotion.io import load_motion
    from headmotion.io.audio import load_audio

    base = shared_data / "mocap_speech/zeggs/067_Speech_2_x_1_0"
    m = load_motion(base.with_suffix(".bvh"))
    a = load_audio(base.with_suffix(".wav"))
    mask = R.speech_mask_for(a, m)
    row = R.realism(m, m, speech_mask=mask, onsets=R.speech_onsets(a))
    # real mocap: most power below 0.5 Hz, little in 1.5-4 Hz, no limit cycle, slower in pauses
    assert row["band_0_0.5"] > 0.6 and row["band_1.5_4"] < 0.05
    assert row["limit_cycle"] < 0.3
    assert 0.2 < row["pause_ratio"] < 0.6
    assert row["bc"] > 0.5


def test_long_rows():
    ref = sine(0.3, seconds=20)
    rows = R.realism_rows({"gt": [ref]}, [ref])
    lr = R.long_rows(rows)
    assert {r["system"] for r in lr} == {"gt"} and {r["recording"] for r in lr} == {"rec0", "ALL"}
    got = {(r["recording"], r["metric"]): r["value"] for r in lr}
    assert got[("rec0", "realism_spectral_l1")] == 0.0
