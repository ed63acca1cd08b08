"""The DNN systems' two training data paths, chosen by ``train_path`` (``auto``, ``memory``,
``streamed``; ``docs/decisions/bounded-training.md``), on any device.

Known answers: the streamed path trains an in-memory corpus whose validation recordings are all
shorter than a post-filter segment (as the cross-fitted halves of a corpus of short clips are),
and its post-filter then validates on the training segments the in-memory path takes; the two
paths give the same normalisers and close models on real recordings (the ZEGGS take of
``../shared``, skipped when absent); the path and the device are checked."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.cli import main
from headmotion.corpus import Corpus, Recording
from headmotion.errors import ParameterError
from headmotion.models import nets
from headmotion.systems import create
from headmotion.systems.dnn import stream_training, streamed
from headmotion.types import Audio, Motion

SMALL = {"max_epochs": 2, "patience": 2}


def _cut(rec: Recording, a: float, b: float, rid: str, split: str) -> Recording:
    """Seconds ``[a, b)`` of ``rec`` as a new recording in ``split``."""
    sr, fps = rec.audio.sample_rate, rec.motion.fps
    audio = Audio(rec.audio.samples[int(a * sr):int(b * sr)], sr)
    motion = Motion(rec.motion.rotvec[int(round(a * fps)):int(round(b * fps))], fps)
    return Recording.aligned(rid, rec.speaker, rec.task, audio, motion, split=split)


@pytest.fixture(scope="module")
def short_valid(planted):
    """Two speakers, three 15 s training takes each and one validation take of 0.3 s (30 frames
    at 100 fps, shorter than the 50-frame post-filter segment)."""
    base = planted(minutes=2.0, n_recordings=4, speakers=("a", "b"), seed=5)
    recs = []
    for r in base:
        last = r.id.endswith("_003")
        recs.append(_cut(r, 0.0, 0.3 if last else r.duration, r.id, "valid" if last else "train"))
    return Corpus(recs, sample_rate=base.sample_rate)


def test_streamed_path_trains_in_memory_corpora_with_short_validation_recordings(short_valid):
    model = create("mfcc-dnn", **SMALL, train_path="streamed").fit(short_valid)
    assert model.history_["streamed"] is True and model.history_["device"] == "cpu"
    assert model.history_["postfilter"]["valid_from_training"] is True
    assert np.isfinite(model.history_["postfilter"]["valid"]).all()
    assert model.speed_map_ is not None  # the cross-fitted halves (in-memory corpora) streamed too
    out = model.predict(short_valid[0].audio, seed=0).rotvec
    assert out.shape == (len(short_valid[0].motion), 3) and np.isfinite(out).all() and out.std(axis=0).min() > 0
    memory = create("mfcc-dnn", **SMALL, train_path="memory").fit(short_valid)
    assert "streamed" not in memory.history_
    np.testing.assert_allclose(model.feature_norm_.mean_, memory.feature_norm_.mean_, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(model.motion_norm_.std_, memory.motion_norm_.std_, rtol=1e-9)


def test_fallback_validation_segments_are_the_in_memory_ones(short_valid):
    system = create("mfcc-dnn", **SMALL)
    ids = list(short_valid.ids)
    train = [i for i, r in enumerate(short_valid) if r.split == "train"]
    valid = [i for i in range(len(ids)) if i not in train]
    with streamed.build(system, short_valid, train, valid, system._feature_config()) as data:
        got = stream_training.fallback_valid_segments(data, 50).numpy()
        tr = nets.motion_segments([data.load(p).y for p in data.train], segment=50, hop=5)
    want = tr[:: max(1, len(tr) // 200)].reshape(-1, 150)
    assert len(tr) == 6 * ((1500 - 50) // 5 + 1) and 200 <= len(got) < 220
    np.testing.assert_array_equal(got, want)


def test_train_path_is_checked_and_decides_the_path(short_valid, tmp_path, capsys):
    with pytest.raises(ParameterError, match="'train_path' parameter of mfcc-dnn must be one of"):
        create("mfcc-dnn", train_path="disk").fit(short_valid)
    with pytest.raises(ParameterError, match="cccae trains in memory only"):
        create("cccae", train_path="streamed").fit(short_valid)
    idx = list(range(len(short_valid)))
    assert not streamed.uses_stream(create("mfcc-dnn"), short_valid, idx)  # in memory: auto keeps it there
    assert streamed.uses_stream(create("mfcc-dnn", train_path="streamed"), short_valid, idx)
    assert not streamed.uses_stream(create("cccae", device="auto"), short_valid, idx)
    code = main(["train", str(tmp_path), "-s", "tws-basic", "-o", str(tmp_path / "m.hmz"), "--train-path", "memory"])
    said = " ".join(capsys.readouterr().err.split())
    assert code != 0 and "--train-path is not a parameter of tws-basic" in said


def test_train_path_flows_from_the_command_line(tmp_path, capsys):
    from headmotion.datasets import import_dataset
    from headmotion.datasets.planted import write_planted_beat2
    from headmotion.systems import load_model

    write_planted_beat2(tmp_path / "beat2", hours=0.05, take_minutes=0.5, speakers=2, seed=1)
    assert not import_dataset("beat2", tmp_path / "beat2", tmp_path / "corpus").refused
    out = tmp_path / "m.hmz"
    code = main(["train", str(tmp_path / "corpus"), "-s", "mfcc-dnn[max_epochs=1;patience=1;cross_fit=false]",
                 "-o", str(out), "--train-path", "streamed", "--device", "cpu"])
    assert code == 0, capsys.readouterr().err
    model = load_model(out)
    assert model.get_params()["train_path"] == "streamed" and model.history_["streamed"] is True


def test_cuda_without_a_gpu_is_refused_for_the_autoencoder_systems(short_valid):
    import torch

    if torch.cuda.is_available():
        pytest.skip("this machine has a CUDA device: the refusal cannot be seen")
    for name in ("cccae", "ae-dnn"):
        with pytest.raises(ParameterError, match="no CUDA device"):
            create(name, **SMALL, device="cuda").fit(short_valid)


def _zeggs_corpus(shared_data, parts: int = 8) -> Corpus:
    """The ZEGGS take (68.8 s of speech with its motion capture) cut into ``parts`` recordings."""
    from headmotion.io import load_audio, load_motion

    d = shared_data / "mocap_speech" / "zeggs"
    bvh, wav = d / "067_Speech_2_x_1_0.bvh", d / "067_Speech_2_x_1_0.wav"
    if not (bvh.exists() and wav.exists()):
        pytest.skip(f"{d} lacks the ZEGGS BVH + wav pair")
    whole = Recording.aligned("zeggs", "zeggs", "speech", load_audio(wav), load_motion(bvh))
    step = whole.duration / parts
    return Corpus([_cut(whole, k * step, (k + 1) * step, f"zeggs_{k}", None) for k in range(parts)],
                  sample_rate=whole.audio.sample_rate)


@pytest.mark.shared
@pytest.mark.slow
def test_streamed_and_memory_models_agree_on_real_recordings(shared_data):
    corpus = _zeggs_corpus(shared_data)
    params = {"max_epochs": 4, "patience": 4}
    memory = create("mfcc-dnn", **params, train_path="memory").fit(corpus)
    stream = create("mfcc-dnn", **params, train_path="streamed").fit(corpus)
    assert stream.history_["streamed"] is True and "streamed" not in memory.history_
    vm, vs = memory.history_["regressor"]["valid"], stream.history_["regressor"]["valid"]
    assert abs(min(vs) - min(vm)) < 0.05 * min(vm)
    # the outputs on all 69 s of speech (on the first 8.6 s part alone pitch correlates 0.90, on all 0.97)
    a = np.concatenate([memory.predict(r.audio, seed=0).rotvec for r in corpus])
    b = np.concatenate([stream.predict(r.audio, seed=0).rotvec for r in corpus])
    for j in range(3):
        assert np.corrcoef(a[:, j], b[:, j])[0, 1] > 0.9
        assert 0.8 < b[:, j].std() / a[:, j].std() < 1.25


def test_prefetch_keeps_the_order_and_raises_the_readers_error():
    clock = stream_training.EpochClock()
    for depth in (0, 1, 2):
        assert list(stream_training._ahead(iter(range(7)), depth, clock)) == list(range(7))

    def broken():
        yield 1
        raise OSError("scratch file gone")

    with pytest.raises(OSError, match="scratch file gone"):
        list(stream_training._ahead(broken(), 2, clock))


def test_streamed_epochs_are_timed_by_part_and_the_post_filter_reads_motion_only(short_valid):
    model = create("mfcc-dnn", **SMALL, train_path="streamed", cross_fit=False).fit(short_valid)
    for stage in ("regressor", "postfilter"):
        sec = model.history_[stage]["seconds"]
        assert sec["epochs"] == 2 and set(stream_training.CLOCK_PARTS) <= set(sec)
        assert sec["compute"] > 0 and sec["transfer"] == 0.0  # the CPU: nothing to copy
        assert sum(sec[k] for k in ("transfer", "compute", "wait", "valid")) <= sec["total"] * 1.01 + 0.01
    system = create("mfcc-dnn")
    train = [i for i, r in enumerate(short_valid) if r.split == "train"]
    with streamed.build(system, short_valid, train, [], system._feature_config()) as data:
        full, motion = data.load(data.train[0]), data.load(data.train[0], features=False)
        assert motion.feats is None and motion.x is None
        np.testing.assert_array_equal(motion.y, full.y)
        np.testing.assert_array_equal(motion.speaking, full.speaking)


def test_a_planted_dataset_too_small_for_a_training_split_says_so(tmp_path):
    from headmotion.datasets.planted import write_planted_beat2

    # 2 speakers × 1 take each: both takes go to test; at least 5 takes leave one for training
    with pytest.raises(ParameterError, match=r"gives 2 take\(s\) over 2 speaker\(s\), none of them for training.*"
                                             r"at least 5 takes are needed \(hours >= 0\.0417"):
        write_planted_beat2(tmp_path / "beat2", hours=0.02, take_minutes=0.5, speakers=2)
    assert not (tmp_path / "beat2").exists()
    root = write_planted_beat2(tmp_path / "ok", hours=5 * 0.5 / 60, take_minutes=0.5, speakers=2)
    rows = (root / "train_test_split.csv").read_text().split()[1:]
    assert [r.split(",")[1] for r in rows] == ["test", "test", "val", "val", "train"]
