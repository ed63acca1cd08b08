"""Cross-validation protocols (headmotion.evaluation.protocol.protocols) with tiny systems of our own."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.corpus import Corpus, Recording
from headmotion.errors import ParameterError
from headmotion.evaluation.protocol import protocols as P
from headmotion.evaluation.protocol.folds import longest_held_out
from headmotion.systems.base import Synthesizer
from headmotion.types import Audio, FeatureTrack, Motion

SR = 8000
FPS = 50.0


def envelope(audio: Audio, *, fps: float, n_frames: int) -> FeatureTrack:
    """Frame log-energy and its Δ (a stand-in for f0e in these tests)."""
    hop = int(audio.sample_rate / fps)
    s = np.asarray(audio.samples[: n_frames * hop], dtype=float)
    s = np.pad(s, (0, max(0, n_frames * hop - len(s))))
    e = np.log(np.mean(s.reshape(n_frames, hop) ** 2, axis=1) + 1e-8)
    return FeatureTrack(np.column_stack([e, np.gradient(e)]), fps, ("loge", "dloge"))


def _smooth(x, width=9):
    k = np.hanning(width)
    return np.convolve(x, k / k.sum(), mode="same")


def make_corpus(n_per_speaker=3, speakers=("A", "B"), seconds=12.0, seed=0) -> Corpus:
    rng = np.random.default_rng(seed)
    recs = []
    for spk in speakers:
        for k in range(n_per_speaker):
            T = int(seconds * FPS)
            gate = _smooth((rng.random(T) < 0.3).astype(float) * rng.uniform(0.2, 1.0, T), 15) + 0.01
            amp = np.repeat(gate, SR // int(FPS))
            audio = Audio((rng.normal(size=len(amp)) * amp * 0.3).astype(np.float32), SR)
            e = envelope(audio, fps=FPS, n_frames=T).values[:, 0]
            e = (e - e.mean()) / e.std()
            rv = np.column_stack([0.05 * _smooth(e), 0.03 * _smooth(np.roll(e, 3)), 0.01 * _smooth(rng.normal(size=T), 25)])
            recs.append(Recording(f"{spk}{k}", spk, "read" if k % 2 else "free", audio, Motion(rv, FPS)))
    return Corpus(recs, sample_rate=SR)


class EnergyFollower(Synthesizer):
    """Learns a linear map from frame energy to rotation (plus seeded noise)."""

    name = "energy-follower"

    def __init__(self, random_state=0):
        self.random_state = random_state

    def fit(self, corpus, *, progress=None):
        X, Y = [], []
        for r in corpus:
            f = envelope(r.audio, fps=r.motion.fps, n_frames=len(r.motion)).values
            X.append(np.column_stack([f, np.ones(len(f))]))
            Y.append(r.motion.rotvec)
        self.coef_ = np.linalg.lstsq(np.vstack(X), np.vstack(Y), rcond=None)[0]
        self.fps_ = corpus[0].motion.fps
        self.mean_pose_ = np.zeros(3)
        self.fitted_ = True
        return self

    def _predict(self, audio, *, seed=None):
        n = int(round(audio.duration * self.fps_))
        f = envelope(audio, fps=self.fps_, n_frames=n).values
        rng = np.random.default_rng(seed)
        return Motion(np.column_stack([f, np.ones(n)]) @ self.coef_ + 0.002 * rng.normal(size=(n, 3)), self.fps_)

    def _get_state(self):
        return {}, {"coef": self.coef_}

    def _set_state(self, config, arrays):
        self.coef_ = arrays["coef"]


class Stillness(EnergyFollower):
    name = "still-test"

    def _predict(self, audio, *, seed=None):
        n = int(round(audio.duration * self.fps_)) + 1  # one frame too many: trimmed by the protocol
        return Motion(np.zeros((n, 3)), self.fps_)


SYSTEMS = [("energy", EnergyFollower), ("still", Stillness)]


@pytest.fixture(scope="module")
def corpus():
    return make_corpus()


@pytest.fixture(scope="module")
def loo(corpus):
    return P.evaluate(corpus, SYSTEMS, protocol="loo", features=envelope, n_shifts=40, seed=3, window_s=3.0,
                      feature_sets=[])


def test_loo_rows_and_orderings(loo, corpus):
    # the floor (other speakers' recorded heads) comes after the ground truth when every fold has them
    assert loo.systems == ["ground-truth", "floor", "energy", "still"]
    assert sorted(loo.recordings) == sorted(corpus.ids)
    assert loo.config["folds"] == 6
    for system in loo.systems:
        assert len(loo.values(system, "nmse")) == 6
    assert loo.mean("ground-truth", "nmse") == 0.0
    assert loo.mean("ground-truth", "cca_global") == pytest.approx(1.0, abs=1e-6)
    # the learnt system follows the speech: beats chance and the still head
    assert loo.mean("energy", "nmse_rx") < 0.3  # rz is unpredictable noise
    assert loo.mean("energy", "cca_local") > loo.mean("energy", "cca_local_null_p95")
    assert loo.mean("energy", "cca_local_excess") > 0.2
    assert loo.mean("still", "fcca") == 0.0
    assert loo.mean("still", "nmse") == pytest.approx(1.0, abs=0.5)
    assert loo.mean("still", "sd_rx") == 0.0
    # FCCA of the original is the top of the scale; the paper's chance score exists (2 speakers)
    assert loo.mean("ground-truth", "fcca") >= loo.mean("energy", "fcca") - 0.05
    assert 0 < loo.mean("ground-truth", "paper_chance") < 1
    # Fig 4.8 rows per speaker
    assert len(loo.values("ground-truth", "winlocal[2s]")) == 2
    # trajectories kept for one recording
    assert set(loo.trajectories) == {"ground-truth", "floor", "energy", "still"}
    # cross-speaker coupling and beat alignment per recording, pooled like FCCA
    assert len(loo.values("energy", "xcca_p")) == 6 and len(loo.values("energy", "xcca_p_pooled")) == 1
    assert len(loo.values("ground-truth", "xcca_excess")) == 6
    assert len(loo.values("still", "reversals_yaw")) == 1 and loo.mean("still", "reversals_yaw") == 0.0
    assert loo.trajectories["still"].shape == loo.trajectories["ground-truth"].shape


def test_rerun_and_parallel_identical(loo, corpus):
    again = P.evaluate(corpus, SYSTEMS, protocol="loo", features=envelope, n_shifts=40, seed=3, window_s=3.0,
                       feature_sets=[], n_jobs=2)
    assert again.rows == loo.rows


def test_split_protocol(corpus):
    res = P.evaluate(corpus, SYSTEMS[:1], protocol="split", features=envelope, n_shifts=20, seed=0, window_s=3.0,
                     feature_sets=[], fig48=False)
    assert res.config["folds"] == 2  # one per speaker
    assert len(res.recordings) == 2  # 3 recordings per speaker -> 1 test each


def test_bad_arguments(corpus):
    with pytest.raises(ParameterError, match="protocol"):
        P.evaluate(corpus, SYSTEMS, protocol="kfold", features=envelope)
    with pytest.raises(ParameterError, match="unknown system"):
        P.evaluate(corpus, ["no-such-system"], features=envelope)
    with pytest.raises(ParameterError, match="twice"):
        P.evaluate(corpus, [SYSTEMS[0], SYSTEMS[0]], features=envelope)


@pytest.mark.slow
def test_dask_local_cluster_equals_local_run(loo, corpus):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        res = P.evaluate(corpus, SYSTEMS, protocol="loo", features=envelope, n_shifts=40, seed=3, window_s=3.0,
                         feature_sets=[], scheduler=cluster.scheduler_address)
    assert res.rows == loo.rows


def test_registered_anchors(corpus):
    res = P.evaluate(corpus, ["desync", "other-speaker", "shaped-noise", "still"], protocol="loo", features=envelope,
                     n_shifts=20, seed=1, window_s=3.0, feature_sets=[], fig48=False)
    assert res.systems == ["ground-truth", "floor", "desync", "other-speaker", "shaped-noise", "still"]
    for s in res.systems:
        assert len(res.values(s, "fcca")) == 6, s
    assert res.mean("still", "sd_rx") == pytest.approx(0.0, abs=1e-12)
    assert res.mean("still", "fcca") == pytest.approx(0.0, abs=1e-9)
    # unsynchronised motion keeps the amplitude but loses the relation to speech
    assert res.mean("desync", "sd_rx") == pytest.approx(res.mean("ground-truth", "sd_rx"), rel=0.2)
    for s in ("desync", "other-speaker", "shaped-noise"):
        assert res.mean(s, "fcca") < res.mean("ground-truth", "fcca") - 0.3
        assert abs(res.mean(s, "cca_local_excess")) < 0.2


class Broken(EnergyFollower):
    name = "broken"

    def fit(self, corpus, *, progress=None):
        raise ParameterError("cannot learn from this little data")


def test_failing_system_is_reported_not_fatal(corpus):
    res = P.evaluate(corpus, [("broken", Broken), SYSTEMS[0]], features=envelope, n_shifts=10, window_s=3.0,
                     feature_sets=[], fig48=False)
    assert len(res.values("energy", "nmse")) == 6
    assert len(res.values("broken", "nmse")) == 0
    assert len(res.warnings) == 6 and "cannot learn" in res.warnings[0]
    with pytest.raises(ParameterError, match="cannot learn"):
        P.evaluate(corpus, [("broken", Broken)], features=envelope, n_shifts=10, feature_sets=[], strict=True)


def test_evaluate_cli_writes_report(corpus, tmp_path):
    import csv

    from headmotion.cli import main

    corpus.save(tmp_path / "corpus")
    out = tmp_path / "report"
    code = main(["evaluate", str(tmp_path / "corpus"), "--systems", "desync,still", "-o", str(out), "--shifts", "20",
                 "--feature-table", "none", "--seed", "2"])
    assert code == 0
    with open(out / "metrics.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert set(rows[0]) == {"system", "recording", "metric", "value"}
    assert {r["system"] for r in rows} == {"ground-truth", "floor", "desync", "still"}
    md = (out / "report.md").read_text()
    assert "paper Table 2" in md and "Tables 5.3 / 5.8" in md
    assert {p.name for p in (out / "figures").iterdir()} >= {"sd_bars.png", "fcca_per_condition.png", "trajectories.png"}
    assert main(["evaluate", str(tmp_path / "corpus"), "--systems", "nonsense", "-o", str(out)]) != 0


# -- corpus-wide feature extraction and paper Table 1 (evaluation/protocol/feature_table.py) ----------------------
@pytest.fixture(scope="module")
def dask_cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as c:
        yield c


def _assert_same_features(a, b, ids, names):
    assert set(a.tracks) == set(b.tracks) == set(ids)
    for rid in ids:
        assert set(a[rid]) == set(b[rid]) == set(names)
        for fs in names:
            np.testing.assert_array_equal(a[rid][fs].values, b[rid][fs].values)
            assert a[rid][fs].fps == b[rid][fs].fps


def test_extract_corpus_features_local_joblib_and_dask(corpus, dask_cluster):
    from headmotion.evaluation.protocol.feature_table import extract_corpus_features

    fsets = ["fbank", envelope]
    local = extract_corpus_features(corpus, fsets)
    for r in corpus:  # aligned with the motion by default
        assert local[r.id]["fbank"].values.shape == (len(r.motion), 27)
        np.testing.assert_array_equal(local[r.id]["envelope"].values,
                                      envelope(r.audio, fps=FPS, n_frames=len(r.motion)).values)
    _assert_same_features(local, extract_corpus_features(corpus, fsets, n_jobs=2), corpus.ids, ["fbank", "envelope"])
    _assert_same_features(local, extract_corpus_features(corpus, fsets, scheduler=dask_cluster.scheduler_address),
                          corpus.ids, ["fbank", "envelope"])
    at100 = extract_corpus_features(corpus, ["fbank"], fps=100.0)
    assert at100[corpus.ids[0]]["fbank"].values.shape == (1200, 27)  # 12 s at 100 fps
    assert at100[corpus.ids[0]]["fbank"].fps == 100.0


def test_extract_corpus_features_from_disk_on_dask(corpus, dask_cluster, tmp_path):
    """An on-disk corpus travels to the workers as manifest entries and is read there."""
    from headmotion.evaluation.protocol.feature_table import extract_corpus_features

    corpus.subset([0, 1, 3]).save(tmp_path / "c")
    disk = Corpus.load(tmp_path / "c", sample_rate=SR)
    remote = extract_corpus_features(disk, ["mfcc"], scheduler=dask_cluster.scheduler_address)
    assert not disk._cache  # nothing was loaded in this process
    _assert_same_features(extract_corpus_features(disk, ["mfcc"]), remote, disk.ids, ["mfcc"])


def test_extract_corpus_features_errors(corpus):
    from headmotion.evaluation.protocol.feature_table import extract_corpus_features

    def broken(audio, *, fps, n_frames):
        raise ValueError("no such thing")

    with pytest.raises(ValueError, match="no such thing"):
        extract_corpus_features(corpus.subset([0]), [broken])
    res = extract_corpus_features(corpus.subset([0, 1]), [envelope, broken], on_error="skip")
    assert set(res[corpus.ids[0]]) == {"envelope"}
    assert res.errors[(corpus.ids[1], "broken")] == "ValueError: no such thing"
    with pytest.raises(ParameterError, match="on_error"):
        extract_corpus_features(corpus, [envelope], on_error="ignore")


TABLE_KW = dict(protocol="split", features=envelope, n_shifts=20, seed=5, window_s=3.0, fig48=False)


def test_feature_table_on_dask_equals_local(corpus, dask_cluster):
    local = P.evaluate(corpus, SYSTEMS[:1], feature_sets=["fbank", envelope], **TABLE_KW)
    remote = P.evaluate(corpus, SYSTEMS[:1], feature_sets=["fbank", envelope], scheduler=dask_cluster.scheduler_address,
                        **TABLE_KW)
    assert remote.rows == local.rows
    assert remote.splits == local.splits
    # the table covers every recording of the corpus, not only the 2 held-out ones
    assert len(local.recordings) == 2
    for fs in ("fbank", "envelope"):
        recs = {r["recording"] for r in local.rows if r["metric"] == f"featcca_local[{fs}]"}
        assert recs == set(corpus.ids)


def test_table1_train_valid_test_columns(corpus):
    from headmotion.corpus import paper_split
    from headmotion.evaluation.measures import metrics as M
    from headmotion.evaluation.reporting.report import render_report

    res = P.evaluate(corpus, SYSTEMS[:1], feature_sets=[envelope], **TABLE_KW)
    split = paper_split(corpus, seed=5)
    assert res.splits == split and res.config["splits"] == split
    assert sorted(split.values()) == ["test"] * 2 + ["train"] * 2 + ["valid"] * 2
    md = render_report(res)
    assert "| Feature | Speaker | train (n=2) | valid (n=2) | test (n=2) | chance |" in md
    assert "No recordings in" not in md
    # each column is mean ± SD over its recordings of the one local CCA implementation
    for name in ("train", "valid", "test"):
        ids = [rid for rid, s in split.items() if s == name]
        v = [M.local_cca(corpus[rid].motion, envelope(corpus[rid].audio, fps=FPS, n_frames=len(corpus[rid].motion)),
                         window=150) for rid in ids]
        assert f"{np.mean(v):.3f} ± {np.std(v, ddof=1):.3f}" in md, name
    # per-speaker rows (2 speakers) under the pooled row; the excess table follows
    assert "| envelope | A |" in md and "| envelope | all |" in md
    assert "Excess over chance" in md


def test_table1_says_when_a_split_is_empty():
    from headmotion.evaluation.reporting.report import render_report

    small = make_corpus(n_per_speaker=2, seconds=8.0, seed=4)  # 2 recordings per speaker: train + test
    res = P.evaluate(small, SYSTEMS[1:], protocol="loo", features=envelope, n_shifts=10, seed=0, window_s=0.6,
                     feature_sets=[envelope, "fbank"], fig48=False)
    assert sorted(res.splits.values()) == ["test", "test", "train", "train"]
    md = render_report(res)
    assert "valid (n=0)" in md and "| no recordings |" in md
    assert "No recordings in the valid split" in md
    # fbank (27 + 3 dims) does not fit a 30-frame window: one warning for all recordings, not four
    short = [w for w in res.warnings if "'fbank'" in w]
    assert len(short) == 1 and "4 of 4 recordings" in short[0] and "30-frame window" in short[0]
    assert not [r for r in res.rows if r["metric"].startswith("featcca_local[fbank]")]


class Warner(EnergyFollower):
    name = "warner"

    def fit(self, corpus, *, progress=None):
        import warnings

        super().fit(corpus)
        self.fit_warnings_ = ["used fewer clusters"]
        warnings.warn("used fewer clusters", UserWarning, stacklevel=2)
        return self


def test_training_warnings_reach_the_report(corpus):
    res = P.evaluate(corpus.filter(speaker="A"), [("warner", Warner)], features=envelope, n_shifts=10, window_s=3.0,
                     feature_sets=[], fig48=False)
    assert res.warnings == [f"warner, fold A{k}: used fewer clusters" for k in range(3)]


def test_trajectory_default_is_the_longest_held_out_recording(tmp_path):
    import dataclasses

    short = make_corpus(n_per_speaker=2, speakers=("A",), seconds=8.0, seed=1)
    long = dataclasses.replace(make_corpus(n_per_speaker=1, speakers=("A",), seconds=14.0, seed=2)[0], id="A2")
    mem = Corpus(list(short) + [long], sample_rate=SR)
    res = P.evaluate(mem, SYSTEMS[1:], features=envelope, n_shifts=10, window_s=3.0, feature_sets=[], fig48=False)
    assert res.trajectory_recording == "A2"
    mem.save(tmp_path / "c")
    disk = Corpus.load(tmp_path / "c", sample_rate=SR)
    folds = P.make_folds(disk, "loo")
    assert longest_held_out(folds) == "A2"
    assert not any(test._cache for _, _, test, _ in folds)  # the fold tasks stay lazy
