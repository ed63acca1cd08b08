"""Corpus statistics (thesis §3.5) — headmotion.evaluation.corpus_stats."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.corpus import Corpus, Recording
from headmotion.errors import ParameterError
from headmotion.evaluation import corpus_stats as CS
from headmotion.evaluation.reporting import stats_report as report
from headmotion.types import Audio, Motion

SR = 16000


def bursts(n, *, syl=0.15, gap=0.1, f0=140.0, seed=0) -> Audio:
    """``n`` voiced syllable-like bursts (harmonic tone under a Hann envelope) separated by gaps."""
    rng = np.random.default_rng(seed)
    parts = [np.zeros(int(0.3 * SR))]
    t = np.arange(int(syl * SR)) / SR
    for _ in range(n):
        s = sum(np.sin(2 * np.pi * f0 * h * t) / h for h in range(1, 8)) * np.hanning(len(t)) * rng.uniform(0.3, 0.8)
        parts += [s, np.zeros(int(gap * SR))]
    x = np.concatenate(parts) + 1e-4 * rng.normal(size=sum(len(p) for p in parts))
    return Audio((0.5 * x / np.abs(x).max()).astype(np.float32), SR)


@pytest.mark.parametrize("n", [12, 30])
def test_syllable_nuclei_counts_bursts(n):
    r = CS.syllable_nuclei(bursts(n, seed=n))
    assert r["syllables"] == n
    assert r["speech_rate"] == pytest.approx(n / r["duration_s"])
    assert 0 < r["phonation_s"] <= r["duration_s"]


def test_syllable_nuclei_silence():
    r = CS.syllable_nuclei(Audio(np.zeros(SR, np.float32), SR))
    assert r["syllables"] == 0 and r["speech_rate"] == 0


def test_syllable_nuclei_real_speech(shared_data):
    from headmotion.io import load_audio

    # "And so, my fellow Americans: ask not what your country can do for you — ask what you can do
    # for your country." — 29 syllables
    r = CS.syllable_nuclei(load_audio(shared_data / "speech" / "jfk.flac", sample_rate=SR))
    assert r["syllables"] == pytest.approx(29, abs=4)


def _brute_force_ce(a, b, lo, hi, n_bins):
    def logp(train, x):
        out = np.zeros(len(x))
        for d in range(train.shape[1]):
            edges = np.linspace(lo[d], hi[d], n_bins + 1)
            c, _ = np.histogram(train[:, d], bins=edges)
            p = (c + 1) / (c + 1).sum()
            idx = np.clip(np.searchsorted(edges, x[:, d], side="right") - 1, 0, n_bins - 1)
            out += np.log(p[idx])
        return out
    return np.mean(logp(a, a) - logp(b, a)) + np.mean(logp(b, b) - logp(a, b))


def test_cross_entropy_distance_matches_eq_3_1():
    rng = np.random.default_rng(0)
    obs = [rng.normal(size=(400, 3)), rng.normal(size=(300, 3)) * 1.5 + 0.2, rng.laplace(size=(500, 3))]
    D = CS.cross_entropy_distances(obs, n_bins=20)
    lo = np.min([o.min(0) for o in obs], 0)
    hi = np.max([o.max(0) for o in obs], 0)
    for i in range(3):
        for j in range(3):
            want = 0.0 if i == j else _brute_force_ce(obs[i], obs[j], lo, hi, 20)
            assert D[i, j] == pytest.approx(want, abs=1e-9)
    assert np.allclose(D, D.T) and np.all(D >= 0) and np.all(np.diag(D) == 0)
    # the same distribution is closer than a scaled one
    same = CS.cross_entropy_distances([obs[0], rng.normal(size=(400, 3)), obs[0] * 3])
    assert same[0, 1] < same[0, 2]
    with pytest.raises(ParameterError, match="at least 2"):
        CS.cross_entropy_distances(obs[:1])


def test_classical_mds_and_stress():
    from scipy.spatial.distance import pdist, squareform

    rng = np.random.default_rng(1)
    P = rng.normal(size=(12, 2))
    D = squareform(pdist(P))
    X0 = CS.classical_mds(D)
    s1, s2 = CS.stress(D, X0)
    assert s1 < 1e-8 and s2 < 1e-12
    X, s1, _ = CS.mds(D, seed=0)
    assert s1 < 1e-3
    # distances of a 5-D configuration cannot be embedded in 2-D without stress
    Q = rng.normal(size=(15, 5))
    _, s1q, s2q = CS.mds(squareform(pdist(Q)))
    assert 0.05 < s1q < 0.6 and s2q == pytest.approx(s1q ** 2)


def test_pair_statistics_and_heat_map():
    spk = ["a", "a", "b", "b"]
    tsk = ["read", "free", "read", "free"]
    D = np.array([[0, 1, 4, 5], [1, 0, 6, 7], [4, 6, 0, 2], [5, 7, 2, 0]], float)
    rows = {r["condition"]: r for r in CS.pair_statistics(D, spk, tsk)}
    assert rows["read"]["mean"] == 4 and rows["free"]["mean"] == 7
    assert rows["Between tasks"]["mean"] == 1.5  # (1 + 2) / 2, same speaker only
    assert rows["Within speaker"]["mean"] == 1.5
    assert rows["Between speakers"]["mean"] == pytest.approx((4 + 5 + 6 + 7) / 4)
    names, H = CS.speaker_means(D, spk)
    assert names == ["a", "b"]
    np.testing.assert_allclose(H, [[1, 5.5], [5.5, 2]])
    c = {r["task"]: r for r in CS.rate_distance_correlation(D, [1, 2, 4, 6], tsk)}
    assert c["All"]["pairs"] == 6 and -1 <= c["All"]["correlation"] <= 1


def _corpus():
    rng = np.random.default_rng(3)
    recs = []
    for si, spk in enumerate(("ann", "bob", "cid")):
        for k, task in enumerate(("read", "free", "read", "free")):
            n_syll = 8 + 2 * si + k
            audio = bursts(n_syll, gap=0.1 + 0.05 * si, seed=10 * si + k)
            T = int(round(audio.duration * 50))
            scale = 0.02 * (1 + si)  # speakers differ in how much they move
            rv = np.cumsum(rng.normal(size=(T, 3)), 0) * 0.1
            rv = (rv - rv.mean(0)) / rv.std(0) * scale
            recs.append(Recording.aligned(f"{spk}{k}", spk, task, audio, Motion(rv, 50.0)))
    return Corpus(recs)


def test_corpus_stats_end_to_end(tmp_path):
    st = CS.corpus_stats(_corpus(), seed=0)
    assert st.distances.shape == (12, 12)
    assert st.mds.shape == (12, 2)
    rows = {p["condition"]: p for p in st.pairs}
    # speakers were made to differ in amplitude: within-speaker distances are smaller
    assert rows["Within speaker"]["mean"] < rows["Between speakers"]["mean"]
    assert [r["syllables"] for r in st.recordings[:4]] == [8, 9, 10, 11]
    out = report.write_stats(st, tmp_path / "stats")
    md = out["report"].read_text()
    for heading in ("Table 3.2", "Table 3.3", "Table 3.4", "Table 3.5", "Table 3.6"):
        assert heading in md
    names = {p.name for p in out["figures"]}
    assert {"distributions.png", "mds.png", "heatmap_all.png", "heatmap_read.png", "heatmap_free.png"} <= names
    assert (tmp_path / "stats" / "distances.csv").read_text().count("\n") == 13


def test_stats_cli(tmp_path):
    from headmotion.cli import main

    _corpus().save(tmp_path / "corpus")
    assert main(["stats", str(tmp_path / "corpus"), "-o", str(tmp_path / "out"), "--no-figures"]) == 0
    assert "Table 3.5" in (tmp_path / "out" / "stats.md").read_text()
    assert main(["stats", str(tmp_path / "nothing"), "-o", str(tmp_path / "out2")]) != 0


def test_corpus_stats_feature_table(tmp_path):
    """Paper Table 1 (thesis §5.7.1) in stats.md: one row per feature set, with chance and excess
    columns, the same numbers as ``feature_table`` gives."""
    from headmotion.synthetic import planted_corpus

    corpus = planted_corpus(minutes=0.4, n_recordings=3, fps=50.0, seed=1)
    st = CS.corpus_stats(corpus, speaking_rate=False, feature_sets=["f0e", "prosody"], window_s=3.0, n_shifts=20)
    assert set(st.feature_table) == set(corpus.ids)
    for vals in st.feature_table.values():
        assert {"featcca_local[f0e]", "featcca_local[f0e]_null_mean", "featcca_local[f0e]_excess",
                "featcca_local[prosody]_p"} <= set(vals)
        assert 0.0 < vals["featcca_local[f0e]"] <= 1.0 and 0.0 < vals["featcca_local[f0e]_null_mean"] <= 1.0
        # the excess is the motion's bridge's score over chance (evaluation.measures.chance): close to score − chance
        assert vals["featcca_local[f0e]_excess"] == pytest.approx(
            vals["featcca_local[f0e]"] - vals["featcca_local[f0e]_null_mean"], abs=0.05)
    md = report.write_stats(st, tmp_path / "stats", figures=False)["report"].read_text()
    section = md[md.index("paper Table 1 layout"):]
    cca_table, excess_table = [b.strip() for b in section.split("\n\n") if b.strip().startswith("| Feature |")][:2]
    assert "| chance |" in cca_table and "| p<.05 |" in excess_table
    for table in (cca_table, excess_table):
        rows = [ln for ln in table.splitlines()[2:] if ln.startswith("| ")]
        assert [r.split("|")[1].strip() for r in rows] == ["F0+Energy", "Pitch+Loudness"]
    assert "held-out" not in section.split("##")[1]
    none = CS.corpus_stats(corpus, speaking_rate=False, feature_sets=[])
    assert "paper Table 1" not in report.render_stats(none)
