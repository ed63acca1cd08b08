"""Training in bounded memory: the DNN systems' streamed data path and the GMM/HMM systems' seeded
training budget (``docs/decisions/bounded-training.md``).

Known answers: the streamed normalisers are the concatenated ones; a streamed epoch visits every
speaking frame exactly once; the exact in-memory path is what a small corpus gets (unchanged
model); the streamed model is close to it; the budget's draw is seeded, speaker-balanced and
bounded; ``device='cuda'`` without a GPU is refused."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.cli import main
from headmotion.corpus import Corpus
from headmotion.datasets import import_dataset
from headmotion.datasets.planted import write_planted_beat2
from headmotion.errors import ParameterError
from headmotion.features import Normalizer
from headmotion.systems import create
from headmotion.systems.budget import budget_subset, recording_seconds
from headmotion.systems.dnn import stream_training, streamed

DNN = {"max_epochs": 2, "patience": 2}


@pytest.fixture(scope="module")
def planted(tmp_path_factory):
    """12 takes of 30 s (2 speakers), imported from BEAT2's layout."""
    root = tmp_path_factory.mktemp("scale-train")
    write_planted_beat2(root / "beat2", hours=0.1, take_minutes=0.5, speakers=2, seed=3)
    assert not import_dataset("beat2", root / "beat2", root / "corpus").refused
    return root / "corpus"


@pytest.fixture(scope="module")
def both_models(planted):
    """mfcc-dnn on the planted corpus in memory (the exact path) and streamed from disk."""
    exact = create("mfcc-dnn", **DNN).fit(Corpus.load(planted))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(streamed, "STREAM_MIN_SECONDS", 0.0)
        stream = create("mfcc-dnn", **DNN).fit(Corpus.load(planted))
    return exact, stream


def test_moments_equal_the_concatenated_statistics():
    rng = np.random.default_rng(0)
    blocks = [rng.normal(loc=100.0 * k, scale=1 + k, size=(n, 5)) for k, n in enumerate([1, 7, 300, 0, 41])]
    m = streamed.Moments()
    for b in blocks:
        m.add(b)
    ref = Normalizer().fit([b for b in blocks if len(b)])
    got = m.normalizer()
    assert got.n_frames_ == ref.n_frames_ == 349
    np.testing.assert_allclose(got.mean_, ref.mean_, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(got.std_, ref.std_, rtol=1e-12, atol=1e-9)
    c = streamed.Moments()
    c.add(np.ones((4, 2)))
    assert np.array_equal(c.normalizer().std_, [1.0, 1.0])  # constant dimensions: SD 1, as Normalizer
    with pytest.raises(ParameterError):
        streamed.Moments().normalizer()


def test_small_corpora_keep_the_exact_path(both_models):
    exact, stream = both_models
    assert "streamed" not in exact.history_ and stream.history_["streamed"] is True
    assert stream.history_["device"] == "cpu"


def test_streamed_statistics_equal_the_in_memory_ones(both_models):
    exact, stream = both_models
    for a, b in ((exact.feature_norm_, stream.feature_norm_), (exact.motion_norm_, stream.motion_norm_)):
        assert a.n_frames_ == b.n_frames_
        np.testing.assert_allclose(b.mean_, a.mean_, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(b.std_, a.std_, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(stream.mean_pose_, exact.mean_pose_, rtol=1e-9, atol=1e-12)
    # within the calibration budget the subsample is every training recording: the same range table
    np.testing.assert_allclose(stream.range_, exact.range_, rtol=1e-9)
    assert stream.splits_ == exact.splits_ and stream.input_dim_ == exact.input_dim_


def test_streamed_model_is_close_to_the_exact_one(both_models, planted):
    exact, stream = both_models
    ve, vs = exact.history_["regressor"]["valid"], stream.history_["regressor"]["valid"]
    assert len(ve) == len(vs) == 2 and abs(vs[-1] - ve[-1]) < 0.05 * ve[-1]
    rec = Corpus.load(planted)[0]
    a, b = exact.predict(rec.audio, seed=0).rotvec, stream.predict(rec.audio, seed=0).rotvec
    assert a.shape == b.shape
    for j in range(3):
        assert np.corrcoef(a[:, j], b[:, j])[0, 1] > 0.9
        assert 0.8 < b[:, j].std() / a[:, j].std() < 1.25


def test_an_epoch_reads_every_speaking_frame_once(planted):
    system = create("mfcc-dnn", **DNN)
    c = Corpus.load(planted)
    split = {rid: "train" for rid in c.ids}
    config = system._feature_config()
    with streamed.build(system, c, list(range(len(c))), [], config) as data:
        folder = data.folder
        assert len(data.train) == len(data.valid) == 12  # validation tails, no validation recordings
        want = np.concatenate([data.load(p).y[data.load(p).speaking] for p in data.train])
        order = np.random.default_rng(1).permutation(len(data.train))
        bufs = list(data.buffers(data.train, order, limit=4000))
        assert len(bufs) > 2 and sum(len(b) for b in bufs) == 12
        seen = np.concatenate([stream_training._windows(b, 25)[2] for b in bufs])
        assert len(seen) == data.n_speaking == len(want)
        key = lambda a: a[np.lexsort(a.T[::-1])]  # noqa: E731
        assert np.array_equal(key(seen), key(want))
        # and the frames a batch gathers are the frames' own windows
        seq, starts, targets = stream_training._windows(bufs[0], 25)
        p = bufs[0][0]
        first = np.flatnonzero(p.speaking)[0]
        np.testing.assert_array_equal(seq.data[starts[0] + 25].numpy(), p.x[first])
    assert split and not folder.exists()  # the scratch folder is removed after use


def test_training_budget_draw_is_seeded_bounded_and_balanced(planted):
    c = Corpus.load(planted)
    secs = [recording_seconds(c, i) for i in range(len(c))]
    assert secs == pytest.approx([c[i].duration for i in range(len(c))], abs=0.5)
    assert budget_subset(c, None) == list(range(12)) == budget_subset(c, sum(secs) + 1)
    a, b = budget_subset(c, 100.0, seed=0), budget_subset(c, 100.0, seed=0)
    assert a == b and a == sorted(a)
    assert 100.0 <= sum(secs[i] for i in a) < 100.0 + max(secs)  # stops at the first recording past the budget
    speakers = [c.entries[i].speaker for i in a]
    assert abs(speakers.count(speakers[0]) - (len(a) - speakers.count(speakers[0]))) <= 1
    assert any(budget_subset(c, 100.0, seed=s) != a for s in range(1, 6))
    with pytest.raises(ParameterError):
        budget_subset(c, 0.0)


def test_tws_basic_trains_on_its_budget(planted):
    c = Corpus.load(planted)
    small = create("tws-basic", max_train_hours=0.03).fit(c)  # 108 s: 4 of the 12 takes
    assert small.corpus_summary_["trained_on"] == {"recordings": 4, "of": 12, "max_train_hours": 0.03}
    assert small.train_seconds_ == pytest.approx(4 * 30.0, abs=1.0)
    whole = create("tws-basic").fit(c)
    assert whole.train_subsample_ is None and "trained_on" not in whole.corpus_summary_
    assert whole.train_seconds_ == pytest.approx(12 * 30.0, abs=2.0)
    with pytest.raises(ParameterError, match="max_train_hours"):
        create("tws-hier", max_train_hours=-1).fit(c)


def test_device_is_checked(planted, tmp_path, capsys):
    import torch

    with pytest.raises(ParameterError, match="device"):
        create("mfcc-dnn", device="gpu").fit(Corpus.load(planted))
    if torch.cuda.is_available():
        pytest.skip("this machine has a CUDA device: the refusal cannot be seen")
    with pytest.raises(ParameterError, match="no CUDA device"):
        create("mfcc-dnn", device="cuda").fit(Corpus.load(planted))
    capsys.readouterr()
    code = main(["train", str(planted), "-s", "mfcc-dnn", "-o", str(tmp_path / "m.hmz"), "--device", "cuda"])
    said = " ".join(capsys.readouterr().err.split())
    assert code != 0 and "no CUDA device" in said and "Traceback" not in said
    assert not (tmp_path / "m.hmz").exists()
    code = main(["train", str(planted), "-s", "tws-basic", "-o", str(tmp_path / "m.hmz"), "--device", "cpu"])
    said = " ".join(capsys.readouterr().err.split())
    assert code != 0 and "--device is not a parameter of tws-basic" in said
