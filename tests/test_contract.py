"""Every registered system against the one contract, like scikit-learn's
``check_estimator``: :func:`check_synthesizer` runs the same checks on each registry name.

Tiny settings keep the DNN systems fast; the corpus is planted (known structure) and built once
per session (the ``planted`` fixture of conftest.py).
"""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.align import n_frames
from headmotion.errors import NotFittedError, ParameterError
from headmotion.io.audio import resample
from headmotion.rotations import pitch_yaw_roll_to_rotvec, rotvec_to_pitch_yaw_roll
from headmotion.synthesis import synthesize
from headmotion.systems import CAUSAL, EMBEDDING, SYSTEMS, create, load_model
from headmotion.types import Audio

_DNN_TINY = dict(ae_hidden=(16,), embedding_dim=4, regressor_hidden=(16,), context=3, postfilter_hidden=(16,),
                 postfilter_code=4, segment=10, max_epochs=1, ae_max_epochs=1, pretrain_epochs=0, patience=1,
                 cca_batch_size=200, batch_size=256, n_threads=1)

#: small settings per system, and one bad parameter value each
TINY = {
    "tws-basic": dict(n_components=1, n_init=1),
    "tws-hier": dict(n_clusters=2, hmm_iter=2, n_init=2),
    "le2012": dict(n_components=2, max_train_frames=2000, n_steps=4),
    **{name: dict(_DNN_TINY) for name in ("cccae", "ae-dnn", "mfcc-dnn", "fbank-dnn", "f0e-dnn", "wav-dnn")},
    "motion-flow": dict(window=24, prefix=6, hidden=16, n_blocks=2, train_steps=20, batch_size=8, eval_every=10,
                        sampling_steps=2, n_threads=1),
    "motion-match": dict(),
    "adapt": dict(min_speech_s=0.0),
    "loudness-wobble": dict(),
}
BAD = {
    "tws-basic": {"method": "best"},
    "tws-hier": {"stochastic": "sometimes"},
    "le2012": {"n_steps": 0},
    **{name: {"embedding_dim": 0} for name in ("cccae", "ae-dnn", "mfcc-dnn", "fbank-dnn", "f0e-dnn", "wav-dnn")},
    "motion-flow": {"sampling_steps": 0},
    "motion-match": {"temperature": 0.0},
    "adapt": {"min_speech_s": -1.0},
    "loudness-wobble": {"fps": 0.5},
}


def test_every_registered_system_has_settings():
    assert set(TINY) == set(SYSTEMS) == set(BAD)


@pytest.fixture(scope="module")
def corpus(planted):
    return planted(minutes=1.5, n_recordings=3, seed=11)


@pytest.fixture(scope="module")
def audio(corpus):
    return corpus[2].audio.slice_seconds(0, 5.0)


def check_synthesizer(name: str, corpus, audio: Audio, tmp_path) -> None:
    """The contract checks for the system registered as ``name``."""
    # parameters: one get_params / set_params from __init__'s signature, round trip
    model = create(name, **TINY[name])
    params = model.get_params()
    assert set(params) == set(type(model)._param_names())
    again = create(name).set_params(**params)
    assert again.get_params() == params
    with pytest.raises(ParameterError, match="no parameter 'no_such_parameter'"):
        create(name).set_params(no_such_parameter=1)
    # not fitted
    with pytest.raises(NotFittedError):
        model.predict(audio)
    if model.can_stream:  # CAUSAL or STREAMING
        with pytest.raises(NotFittedError):
            model.stream()
    else:
        with pytest.raises(ParameterError, match="cannot stream"):
            model.stream()
    # a bad parameter is accepted by the constructor and refused by fit
    bad = create(name, **{**TINY[name], **BAD[name]})
    with pytest.raises(ParameterError):
        bad.fit(corpus)

    assert model.fit(corpus) is model
    # output length and rate
    out = model.predict(audio, seed=1)
    assert out.fps == model.frame_rate
    assert len(out) == n_frames(len(audio.samples), audio.sample_rate, model.frame_rate)
    assert np.all(np.isfinite(out.rotvec))
    # the same seed gives the same output; the audio may come at any rate
    np.testing.assert_array_equal(model.predict(audio, seed=1).rotvec, out.rotvec)
    other = Audio(resample(audio.samples, audio.sample_rate, 22050), 22050)
    assert abs(len(model.predict(other, seed=1)) - len(out)) <= 1
    assert model.sample_rate == corpus[0].audio.sample_rate
    # gain / offset, applied by the product to every system's motion: one meaning (about the
    # training mean pose, pitch / yaw / roll)
    still = synthesize(audio, model, seed=1, gain=0.0, offset=(0.01, 0.0, -0.02))[0]
    pose = pitch_yaw_roll_to_rotvec(*(model.mean_pose_ + [0.01, 0.0, -0.02]))
    np.testing.assert_allclose(still.rotvec, np.tile(pose, (len(still), 1)), atol=1e-12)
    loud = rotvec_to_pitch_yaw_roll(synthesize(audio, model, seed=1, gain=1.5)[0].rotvec)
    np.testing.assert_allclose(loud.std(axis=0), 1.5 * rotvec_to_pitch_yaw_roll(out.rotvec).std(axis=0), rtol=1e-9)
    # a bad parameter set after fitting is refused by predict
    model.set_params(**BAD[name])
    with pytest.raises(ParameterError):
        model.predict(audio)
    model.set_params(**{k: params[k] for k in BAD[name]})
    # save -> load -> identical output and parameters
    back = load_model(model.save(tmp_path / f"{name}.hmz"))
    assert type(back) is type(model)
    np.testing.assert_array_equal(back.predict(audio, seed=1).rotvec, out.rotvec)
    np.testing.assert_array_equal(back.mean_pose_, model.mean_pose_)
    assert back.get_params() == model.get_params()
    # capabilities are what the object does
    assert model.causal == (CAUSAL in model.capabilities)
    if model.can_stream:
        st = model.stream(seed=1)
        step = model.sample_rate // 100
        x = Audio(resample(audio.samples, audio.sample_rate, model.sample_rate), model.sample_rate).samples
        parts = [st.push(x[i:i + step]) for i in range(0, len(x), step)] + [st.flush()]
        assert sum(len(p) for p in parts) == len(out)
    if EMBEDDING in model.capabilities:
        emb = model.embed(audio, n_frames=len(out))
        assert emb.values.shape == (len(out), model.embedding_dim)


@pytest.mark.parametrize("name", sorted(TINY))
def test_contract(name, corpus, audio, tmp_path, torch_one_thread):
    check_synthesizer(name, corpus, audio, tmp_path)


def test_stochastic_has_one_vocabulary(corpus, audio):
    """``stochastic`` is an ordinary parameter; tws-basic and tws-hier share its words ("class" and
    "cluster" are the thesis's names for "choice" and behave exactly like it)."""
    for name in ("tws-basic", "tws-hier"):
        m = create(name, **TINY[name]).fit(corpus)
        assert m.stochastic == "params"  # sampling is the product default
        base = m.set_params(stochastic="none").predict(audio, seed=1).rotvec
        for word in ("params", "both"):
            m.set_params(stochastic=word)
            assert not np.array_equal(m.predict(audio, seed=1).rotvec, m.predict(audio, seed=2).rotvec), (name, word)
        m.set_params(stochastic="choice")
        choice = m.predict(audio, seed=3).rotvec
        for word in ("class", "cluster"):
            np.testing.assert_array_equal(m.set_params(stochastic=word).predict(audio, seed=3).rotvec, choice)
        m.set_params(stochastic="none")
        np.testing.assert_array_equal(m.predict(audio, seed=2).rotvec, base)
    with pytest.raises(ParameterError, match="no parameter 'stochastic'"):
        create("le2012").set_params(stochastic="both")
