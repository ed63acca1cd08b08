"""Detectability: the classifier two-sample test of recorded against generated head motion."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.evaluation.detection import detectability as D
from headmotion.types import Motion

FPS = 25.0


def _process(rng, seconds: float, fps: float = FPS) -> np.ndarray:
    """Smooth random head motion (radians): white noise through a 1.5 Hz one-pole smoother twice."""
    T = int(seconds * fps)
    x = rng.normal(size=(T + 200, 3))
    a = np.exp(-2 * np.pi * 1.5 / fps)
    for _ in range(2):
        for t in range(1, len(x)):
            x[t] = a * x[t - 1] + (1 - a) * x[t]
    return np.radians(3.0) * x[200:] / x[200:].std(axis=0)


def _sines(rng, seconds: float, fps: float = FPS) -> np.ndarray:
    t = np.arange(int(seconds * fps)) / fps
    f = rng.uniform(0.8, 1.2, size=3)
    return np.radians(4.0) * np.sin(2 * np.pi * f[None] * t[:, None] + rng.uniform(0, 2 * np.pi, 3)[None])


def test_window_statistics_of_a_sine():
    t = np.arange(100) / FPS
    w = np.stack([10 * np.sin(2 * np.pi * 1.0 * t)] * 3, axis=1)[None]  # degrees, 1 Hz, 4 s
    F = dict(zip(D.statistic_names(), D.window_statistics(w)[0]))
    assert F["pitch_sd"] == pytest.approx(10 / np.sqrt(2), rel=0.02)
    assert F["yaw_range"] == pytest.approx(20, rel=0.01)
    assert F["roll_reversals"] == pytest.approx(2 * 1.0 / FPS * 100 / 99, abs=0.011)  # two turns a second
    assert F["pitch_band_0.5_1"] + F["pitch_band_1_2"] > 0.9
    assert F["pitch_speed_q99"] == pytest.approx(2 * np.pi * 10, rel=0.03)
    assert F["coupling_pitch_yaw"] == pytest.approx(1.0)
    still = dict(zip(D.statistic_names(), D.window_statistics(np.zeros((1, 100, 3)))[0]))
    assert still["pitch_still_share"] == 1.0 and still["yaw_sd"] == 0.0
    assert np.isfinite(list(still.values())).all()


def test_preprocessing_makes_frame_rate_and_jitter_irrelevant():
    rng = np.random.default_rng(0)
    t100 = np.arange(1000) / 100.0
    slow = np.radians(5) * np.sin(2 * np.pi * 0.7 * t100)[:, None] * np.ones((1, 3))
    jitter = np.radians(1) * np.sin(2 * np.pi * 20 * t100)[:, None] * rng.choice([-1, 1], size=(1, 3))
    a = D.prepare(Motion(slow + jitter, 100.0))
    b = D.prepare(Motion(slow[::4], 25.0))
    assert a.shape[0] == b.shape[0] == 250
    np.testing.assert_allclose(a[20:-20], b[20:-20], atol=0.15)  # degrees; the 20 Hz jitter is gone
    assert D.cut_windows(a).shape == (4, 100, 3)
    assert D.cut_windows(a[:99]).shape == (0, 100, 3)


def test_folds_never_split_a_recording():
    rng = np.random.default_rng(1)
    real = {f"r{i}": _process(rng, 10) for i in range(6)}
    gen = {f"r{i}": _process(rng, 10) for i in range(6)}
    s = D.make_samples(real, gen, fps=FPS)
    for tr, te in D._folds(s.y, s.groups, 5, 0):
        assert not set(s.groups[tr]) & set(s.groups[te])
    # a long take cut into 4 s chunks: more groups, still never split
    s2 = D.make_samples({"take": _process(rng, 60)}, {"take": _process(rng, 60)}, fps=FPS, chunk_s=12)
    assert len(np.unique(s2.groups)) == 5


def test_two_samples_of_one_process_are_not_told_apart():
    rng = np.random.default_rng(2)
    real = {f"r{i}": _process(rng, 12) for i in range(16)}
    gen = {f"r{i}": _process(rng, 12) for i in range(16)}
    res = D.detectability(real, gen, fps=FPS, seed=0, n_boot=300)
    for sc in res.scores.values():
        lo, hi = sc.ba_ci
        assert lo <= 0.5 + 0.02 and sc.balanced_accuracy < 0.65, sc
    assert res.detectability == max(s.balanced_accuracy for s in res.scores.values())
    assert res.n_real == res.n_generated == 16 * 5


def test_sine_against_noise_is_told_apart():
    rng = np.random.default_rng(3)
    real = {f"r{i}": _sines(rng, 12) for i in range(10)}
    gen = {f"r{i}": np.radians(3.0) * rng.normal(size=(300, 3)) for i in range(10)}  # white noise
    res = D.detectability(real, gen, fps=FPS, seed=0, n_boot=200)
    for sc in res.scores.values():
        assert sc.balanced_accuracy > 0.95 and sc.auc > 0.97 and sc.ba_ci[0] > 0.85
    name, auc = res.top_statistics(1)[0]
    assert abs(auc - 0.5) > 0.45


def test_seeded_and_rows():
    rng = np.random.default_rng(4)
    real = {f"r{i}": _process(rng, 9) for i in range(5)}
    gen = {"sys": {f"r{i}": _sines(rng, 9) for i in range(5)}}
    rows = D.detectability_rows(real, gen, FPS, seed=3, n_boot=50, classifiers=("stats",))
    again = D.detectability_rows(real, gen, FPS, seed=3, n_boot=50, classifiers=("stats",))
    assert rows == again
    d = {(r["system"], r["metric"]): r["value"] for r in rows}
    assert d[("sys", "detect")] == d[("sys", "detect_ba_stats")] > 0.9
    assert d[("ground-truth", "detect_still")] == pytest.approx(1.0)
    assert ("ground-truth", "detect_reversed") in d and ("ground-truth", "detect_phase_randomised") in d
    assert all(r["recording"] == "ALL" for r in rows)


def test_phase_randomised_keeps_the_spectrum():
    rng = np.random.default_rng(5)
    x = _process(rng, 10)
    y = D.phase_randomised(x, rng)
    np.testing.assert_allclose(np.abs(np.fft.rfft(y - y.mean(0), axis=0)), np.abs(np.fft.rfft(x - x.mean(0), axis=0)),
                               rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(y.std(axis=0), x.std(axis=0), rtol=1e-6)
    assert np.abs(np.corrcoef(x[:, 0], y[:, 0])[0, 1]) < 0.5


def test_bad_input():
    with pytest.raises(ParameterError, match="4 s"):
        D.detectability({"a": np.zeros((50, 3))}, {"a": np.zeros((50, 3))}, fps=FPS)
    with pytest.raises(ParameterError, match="classifiers"):
        D.detectability({"a": np.zeros((500, 3))}, {"a": np.zeros((500, 3))}, fps=FPS, classifiers=("svm",))
    with pytest.raises(ParameterError, match="fps"):
        D.prepare(np.zeros((100, 3)))
    with pytest.raises(ParameterError, match="2 groups"):
        D.detectability({"a": np.zeros((500, 3))}, {"a": np.ones((500, 3))}, fps=FPS, classifiers=("stats",))


def test_copied_motion_shares_the_group_of_its_source():
    rng = np.random.default_rng(6)
    real = {f"r{i}": _process(rng, 10) for i in range(4)}
    gen = {"r0": real["r1"][::-1].copy(), "r2": np.vstack([real["r3"], real["r3"][::-1]])[:250], "r3": _process(rng, 10)}
    g = D.copy_groups(real, gen)
    assert g["r0"] == g["r1"] and g["r2"] == g["r3"] and g["r0"] != g["r2"]
    assert D.copied_recordings(real, gen) == {"r0": {"r1"}, "r2": {"r3"}}
    s = D.make_samples(real, gen, fps=FPS, chunk_s=4)
    # the copied recordings r1 and r3 leave the recorded sample (two recordings remain)
    assert not any(g.startswith(("r1#", "r3#")) for g in s.groups[s.y == 0])
    s = D.make_samples({k: real[k] for k in ("r0", "r1", "r3")}, gen, fps=FPS, chunk_s=4)
    assert len(np.unique(s.groups)) == 2  # else merged groups, not cut into chunks
    # a recording against its own reversal: chunk k's reversal is another chunk's content, so the
    # recording stays one group
    take = {"take": _process(rng, 60)}
    s = D.make_samples(take | {"b": _process(rng, 60)}, {"take": take["take"][::-1].copy(), "b": _process(rng, 60)},
                       fps=FPS, chunk_s=12)
    assert {g for g in s.groups if g.startswith("take")} == {"take#0"}
    assert len({g for g in s.groups if g.startswith("b")}) == 5


def test_detect_command(tmp_path, capsys):
    from headmotion.cli import main
    from headmotion.io.native import save_npz

    rng = np.random.default_rng(7)
    (tmp_path / "real").mkdir()
    (tmp_path / "gen").mkdir()
    for i in range(6):
        save_npz(Motion(_sines(rng, 10), FPS), tmp_path / "real" / f"r{i}.npz")
        save_npz(Motion(np.radians(3.0) * rng.normal(size=(250, 3)), FPS), tmp_path / "gen" / f"r{i}.npz")
    fig = tmp_path / "top.png"
    rc = main(["detect", str(tmp_path / "real"), str(tmp_path / "gen"), "--no-cnn", "--figure", str(fig)])
    out = capsys.readouterr().out
    assert rc in (0, None)
    assert "detectability 1.000" in out and fig.stat().st_size > 1000
    assert main(["detect", str(tmp_path / "real"), str(tmp_path / "nothing.npz")]) == 1
    assert "nothing.npz" in capsys.readouterr().err


def test_within_folds_a_copy_of_another_folds_recording_is_not_labelled_both_ways():
    """Within folds each classifier sees only one fold's recordings and the motion made for them (a
    condition replaying *another* fold's recorded motion never meets it labelled "recorded"), every
    window is scored once, and a sine against noise is still told apart."""
    rng = np.random.default_rng(7)
    real = {f"r{i}": _process(rng, 12) for i in range(12)}
    fold = {r: i % 2 for i, r in enumerate(real)}
    s, blocks = D._samples_within(real, real, fold, fps=FPS, chunk_s=None)
    for b in blocks:  # each block holds one fold's recordings only
        assert len({fold[g.split("#")[0]] for g in s.groups[b]}) == 1
    assert sorted(np.concatenate(blocks)) == list(range(len(s.y)))
    sines = {r: _sines(rng, 12) for r in real}
    noise = {r: np.radians(3.0) * rng.normal(size=(300, 3)) for r in real}
    res = D.detectability(sines, noise, fps=FPS, seed=0, n_boot=100, classifiers=("stats",), within=fold)
    assert res.scores["stats"].balanced_accuracy > 0.95
    rows = D.detectability_rows(sines, {"noise": noise}, FPS, seed=0, n_boot=50, classifiers=("stats",),
                                ruler=None, within=fold)
    d = {r["metric"]: r["value"] for r in rows}
    assert d["detect_within_folds"] == 1.0 and d["detect"] > 0.95 and d["detect_pooled"] > 0.95
