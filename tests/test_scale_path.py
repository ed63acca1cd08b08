"""A dataset from its own folder to an evaluation on its own split, with bounded memory.

A corpus on disk keeps its speech on disk (decoded when read, the same samples), keeps only its
recently used recordings, and a system's training reads the feature cache that ``corpus
features`` built (the same features); ``evaluate --protocol dataset`` trains on the corpus's
train + valid recordings and reports on its test recordings.  The folders are planted corpora in
BEAT2's layout (:mod:`headmotion.datasets.planted`)."""

from __future__ import annotations

import csv
import pickle

import numpy as np
import pytest
from typer.testing import CliRunner

from headmotion import corpus as corpus_mod
from headmotion import stored_audio
from headmotion.cli import app, main
from headmotion.corpus import Corpus
from headmotion.datasets import import_dataset
from headmotion.datasets.planted import write_planted_beat2
from headmotion.errors import ParameterError
from headmotion.evaluation.protocol.dataset_split import dataset_split_folds
from headmotion.features import FeatureConfig
from headmotion.feature_cache import build_feature_cache, features_for
from headmotion.stored_audio import StoredAudio
from headmotion.systems import create

runner = CliRunner()


@pytest.fixture(scope="module")
def planted_dir(tmp_path_factory):
    """12 takes of 30 s (2 speakers; per speaker takes 1 test, 2 validation, 3–6 train), imported."""
    root = tmp_path_factory.mktemp("scale")
    write_planted_beat2(root / "beat2", hours=0.1, take_minutes=0.5, speakers=2, seed=3)
    summary = import_dataset("beat2", root / "beat2", root / "corpus")
    assert not summary.refused
    return root


def test_speech_stays_on_disk_and_reads_the_same(planted_dir, monkeypatch):
    c = Corpus.load(planted_dir / "corpus")
    rec = c[0]
    assert isinstance(rec.audio, StoredAudio)
    eager = c._read_entry(c.entries[0]).audio
    assert len(rec.audio) == len(eager) == 30 * 16000 and rec.audio.duration == pytest.approx(30.0)
    assert np.array_equal(rec.audio.samples, eager.samples)
    # a pickled recording (to a worker) carries the file reference, not the speech
    assert len(pickle.dumps(rec.audio)) < 2000 < eager.samples.nbytes
    # the decoded cache keeps at least the last recording and no more than its budget
    monkeypatch.setattr(stored_audio, "CACHE_BYTES", 1)
    stored_audio.clear_cache()
    assert sum(len(r.audio.samples) for r in c) == 12 * 30 * 16000
    assert len(stored_audio._decoded) == 1
    assert np.array_equal(rec.audio.samples, eager.samples)  # decoded again: the same samples
    # the corpus keeps its most recently used recordings only
    monkeypatch.setattr(corpus_mod, "RECORDINGS_KEPT", 3)
    c = Corpus.load(planted_dir / "corpus")
    ids = [r.id for r in c]
    assert list(c._cache) == [9, 10, 11] and ids == c.ids
    assert c[0].id == c.ids[0]


def test_in_memory_corpora_keep_their_recordings():
    from headmotion.synthetic import planted_corpus

    c = planted_corpus(minutes=0.2, n_recordings=2)
    assert c[0] is c[0] and not isinstance(c[0].audio, StoredAudio)


def test_features_for_reads_the_cache(planted_dir, monkeypatch):
    c = Corpus.load(planted_dir / "corpus")
    cfg = FeatureConfig("f0e-live", fps=30.0)
    build_feature_cache(c, cfg, n_jobs=1)
    rec = c[2]
    fresh = cfg.extract(rec.audio, n_frames=900)

    def refuse(self, audio, n_frames=None):
        raise AssertionError("computed instead of read from the cache")

    monkeypatch.setattr(FeatureConfig, "extract", refuse)
    cached = features_for(rec, cfg, 900)
    assert np.array_equal(cached.values, fresh.values) and cached.names == fresh.names
    with pytest.raises(AssertionError):  # another length: computed, as extract would
        features_for(rec, cfg, 899)
    with pytest.raises(AssertionError):  # another configuration: not in the cache
        features_for(rec, FeatureConfig("f0e-live", fps=25.0), 750)


def test_training_from_the_cache_gives_the_same_model(tmp_path):
    root = tmp_path / "c"
    write_planted_beat2(root / "beat2", hours=0.05, take_minutes=0.5, speakers=1, seed=5)
    import_dataset("beat2", root / "beat2", root / "corpus")
    plain = create("tws-basic").fit(Corpus.load(root / "corpus"))
    build_feature_cache(Corpus.load(root / "corpus"), FeatureConfig("f0e-live", fps=30.0), n_jobs=1)
    cached = create("tws-basic").fit(Corpus.load(root / "corpus"))
    audio = Corpus.load(root / "corpus")[0].audio
    a, b = plain.predict(audio, seed=1), cached.predict(audio, seed=1)
    assert np.array_equal(a.rotvec, b.rotvec)


def test_dataset_split_folds_and_refusals(planted_dir):
    c = Corpus.load(planted_dir / "corpus")
    [(name, train, test, others)] = dataset_split_folds(c)
    assert sorted(test.ids) == ["1_planted1_0_1_1", "2_planted2_0_1_1"]
    assert len(train) == 10 and {e.split for e in train.entries} == {"train", "valid"}
    assert train.root == c.root and others is train
    bare = Corpus([type(r)(r.id, r.speaker, r.task, r.audio, r.motion) for r in c])
    with pytest.raises(ParameterError, match="no split column"):
        dataset_split_folds(bare)
    no_test = c.subset([i for i, e in enumerate(c.entries) if e.split != "test"])
    with pytest.raises(ParameterError, match="no recording labelled 'test'"):
        dataset_split_folds(no_test)
    partly = Corpus([bare[0]] + [no_test[i] for i in range(len(no_test))])
    with pytest.raises(ParameterError, match="1 recording.*no split label"):
        dataset_split_folds(partly)


@pytest.mark.slow
def test_whole_path_through_the_commands(tmp_path, capsys):
    """BEAT2 folder → import-dataset → corpus features → train → evaluate --protocol dataset."""
    write_planted_beat2(tmp_path / "beat2", hours=0.1, take_minutes=0.5, speakers=2, seed=7)
    corpus = tmp_path / "corpus"
    res = runner.invoke(app, ["corpus", "import-dataset", "beat2", str(tmp_path / "beat2"), "-o", str(corpus)])
    assert res.exit_code == 0, res.output
    said = " ".join(res.output.split())
    assert "imported 12 recording(s)" in said and "test 2, train 8, valid 2" in said
    res = runner.invoke(app, ["corpus", "features", str(corpus), "--set", "f0e-live", "--fps", "30", "--jobs", "1"])
    assert res.exit_code == 0 and "12 computed" in " ".join(res.output.split()), res.output
    res = runner.invoke(app, ["train", str(corpus), "--system", "tws-basic", "-o", str(tmp_path / "m.hmz")])
    assert res.exit_code == 0 and (tmp_path / "m.hmz").is_file(), res.output
    out = tmp_path / "report"
    res = runner.invoke(app, ["evaluate", str(corpus), "-s", "tws-basic,shaped-noise", "-o", str(out),
                              "--protocol", "dataset", "--no-figures", "--feature-table", "none", "--samples", "0",
                              "--shifts", "20"])
    assert res.exit_code == 0, res.output
    assert "2 held-out recordings, 1 folds" in " ".join(res.output.split())
    with open(out / "metrics.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    recs = {r["recording"] for r in rows if r["recording"] != "ALL" and not r["recording"].startswith("speaker:")}
    assert recs == {"1_planted1_0_1_1", "2_planted2_0_1_1"}
    nmse = {r["system"]: float(r["value"]) for r in rows if r["metric"] == "nmse" and r["recording"] == "1_planted1_0_1_1"}
    assert nmse["ground-truth"] == pytest.approx(0.0) and nmse["tws-basic"] > 0
    assert "dataset" in (out / "report.md").read_text()
    # a corpus without the dataset's split: a clear refusal, no traceback
    (corpus / "corpus.csv").write_text("\n".join(
        ",".join(line.split(",")[:5]) for line in (corpus / "corpus.csv").read_text().splitlines()) + "\n")
    capsys.readouterr()
    code = main(["evaluate", str(corpus), "-s", "tws-basic", "-o", str(tmp_path / "r2"), "--protocol", "dataset"])
    said = " ".join(capsys.readouterr().err.split())
    assert code != 0 and "no split column" in said and "Traceback" not in said
    assert not (tmp_path / "r2").exists()
