"""Synthesis seeds have one home (:mod:`headmotion.seeds`): a seed left out is the model's own
``seed`` parameter, on every path (Python, the command line, the stream), and every path refuses
the same out-of-range seeds with the same message (planted corpus)."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.seeds import DEFAULT_SEED, SEED_MAX, check_seed, model_seed, resolve_seed
from headmotion.synthesis import open_stream, synthesize
from headmotion.systems import create


@pytest.fixture(scope="module")
def corpus(planted):
    return planted(minutes=1.0, n_recordings=2, seed=3)


@pytest.fixture(scope="module")
def model(corpus):
    return create("motion-match", prosody="f0e-live", seed=7).fit(corpus)


def test_a_seed_left_out_is_the_models_own(model, corpus):
    audio = corpus[0].audio.slice_seconds(0, 8.0)
    own = synthesize(audio, model)[0]
    np.testing.assert_array_equal(own.rotvec, synthesize(audio, model, seed=7)[0].rotvec)
    assert not np.array_equal(own.rotvec, synthesize(audio, model, seed=DEFAULT_SEED)[0].rotvec)
    s = open_stream(model)
    x = audio.samples.astype(np.float32)
    rv = np.vstack([np.asarray(s.push(x).rotvec).reshape(-1, 3),
                    np.asarray(s.flush().rotvec).reshape(-1, 3)])
    np.testing.assert_array_equal(rv, own.rotvec)


def test_the_command_line_uses_the_models_own_seed(model, corpus, tmp_path):
    import soundfile as sf

    from headmotion.cli import main
    from headmotion.io import load_motion

    path = model.save(tmp_path / "m.hmz")
    wav = tmp_path / "s.wav"
    sf.write(wav, corpus[0].audio.slice_seconds(0, 6.0).samples, corpus[0].audio.sample_rate)
    assert main(["synth", str(wav), "-m", str(path), "-o", str(tmp_path / "a.npz")]) == 0
    assert main(["synth", str(wav), "-m", str(path), "-o", str(tmp_path / "b.npz"), "--seed", "7"]) == 0
    np.testing.assert_array_equal(load_motion(tmp_path / "a.npz").rotvec, load_motion(tmp_path / "b.npz").rotvec)


@pytest.mark.parametrize("bad", [-1, SEED_MAX + 1, 1.5, "3", True])
def test_every_path_refuses_the_same_seeds(model, corpus, bad):
    audio = corpus[0].audio.slice_seconds(0, 2.0)
    for call in (lambda: check_seed(bad), lambda: synthesize(audio, model, seed=bad),
                 lambda: model.predict(audio, seed=bad), lambda: open_stream(model, seed=bad)):
        with pytest.raises(ParameterError, match=rf"seed \(--seed\) must be a whole number from 0 to {SEED_MAX}"):
            call()


def test_model_seed_falls_back_to_the_default():
    class NoSeed:
        pass

    assert model_seed(NoSeed(), None) == DEFAULT_SEED and model_seed(NoSeed(), 5) == 5


def test_resolve_seed_fills_in_the_models_own_and_checks_it():
    class Own:
        def __init__(self, seed):
            self.seed = seed

    assert resolve_seed(Own(None), None) == DEFAULT_SEED
    assert resolve_seed(Own(7), None) == 7 and resolve_seed(Own(7), 5) == 5
    assert type(resolve_seed(Own(7), np.int64(3))) is int
    with pytest.raises(ParameterError, match=r"from 0 to 4294967295; got -1"):
        resolve_seed(Own(-1), None)  # a bad seed parameter is refused when it fills in
    with pytest.raises(ParameterError, match=rf"from 0 to {SEED_MAX - 1} \(seed \+ samples - 1"):
        resolve_seed(Own(SEED_MAX), None, samples=2)


def test_a_model_whose_seed_is_none_synthesises_with_the_default_seed(corpus):
    """``seed=None`` as a model's parameter is the default seed, in ``predict`` as in ``synthesize``
    (not a fresh draw each call)."""
    audio = corpus[0].audio.slice_seconds(0, 4.0)
    m = create("tws-basic", n_components=1, n_init=1, seed=None).fit(corpus)
    want = m.predict(audio, seed=DEFAULT_SEED).rotvec
    np.testing.assert_array_equal(m.predict(audio).rotvec, want)
    np.testing.assert_array_equal(synthesize(audio, m)[0].rotvec, want)
    assert not np.array_equal(m.predict(audio, seed=1).rotvec, want)  # the seed matters to this model
