"""The DNN systems' stream: streamed == offline ``predict`` within the documented
tolerance (systems/dnn/streaming.py), for any chunking; the stated lookahead; the running-mean post
stage chunk-invariant; PAPER_PARAMS unchanged; ``headmotion stream --input FILE`` with an mfcc-dnn."""

from __future__ import annotations

import json

import numpy as np
import pytest

from headmotion.motion.post import restore as dnn_post

torch = pytest.importorskip("torch")
pytestmark = pytest.mark.usefixtures("torch_one_thread")

SMALL = dict(regressor_hidden=(32,), postfilter_hidden=(32,), postfilter_code=8, max_epochs=2,
             patience=3, batch_size=256, n_threads=1)
#: documented tolerance of stream vs predict (radians; float32 network arithmetic in other batch sizes)
TOL = 1e-6


@pytest.fixture(scope="module")
def corpus():
    from test_cccae import envelope_corpus

    return envelope_corpus(n_recordings=3, seconds=20.0, fps=25.0, seed=11, splits=["train", "train", "valid"])


@pytest.fixture(scope="module")
def mfcc_model(corpus):
    from headmotion.systems import create

    return create("mfcc-dnn", **SMALL).fit(corpus)  # the paper's context (±25) and segments (50)


@pytest.fixture(scope="module")
def cccae_model(corpus):
    from headmotion.systems import create

    return create("cccae", ae_hidden=(64,), ae_max_epochs=2, pretrain_epochs=1, **SMALL).fit(corpus)


def _speech_with_pause(corpus):
    """12 s of the held-out recording with 1.5 s of silence in the middle (the pause path runs)."""
    from headmotion.types import Audio

    a = corpus[2].audio
    x = np.asarray(a.samples[: 12 * a.sample_rate], dtype=np.float32).copy()
    x[5 * a.sample_rate: int(6.5 * a.sample_rate)] = 0.0
    return Audio(x[: len(x) - 77], a.sample_rate)  # an odd length: the last frame is partial


def _streamed(model, samples, sizes, seed):
    st = model.stream(seed=seed)
    out, i, k = [], 0, 0
    while i < len(samples):
        n = sizes[k % len(sizes)]
        out.append(st.push(samples[i:i + n]).rotvec)
        i, k = i + n, k + 1
    out.append(st.flush().rotvec)
    return st, np.concatenate(out)


CHUNKS = {"160": [160], "mixed": [1, 37, 160, 999, 4000, 17], "whole": [10 ** 9]}


@pytest.mark.parametrize("chunks", list(CHUNKS))
@pytest.mark.parametrize("which", ["mfcc", "cccae"])
def test_stream_equals_predict(which, chunks, request, corpus):
    m = request.getfixturevalue(f"{which}_model")
    m.set_params(variance_restore=True, drift_share=0.15, drift_tau_s=4.0, idle=0.4, seed=0)  # product defaults
    audio = _speech_with_pause(corpus)
    off = m.predict(audio, seed=3).rotvec
    st, got = _streamed(m, np.asarray(audio.samples), CHUNKS[chunks], seed=3)
    assert got.shape == off.shape
    err = np.abs(got - off).max()
    assert err < TOL, err
    # the pause was settled: the head moves slower there than in speech (not a no-op path)
    sp = np.linalg.norm(np.diff(off, axis=0), axis=1)
    assert sp[560:640].mean() < 0.7 * sp[100:450].mean()


def test_latency_is_the_documented_budget(mfcc_model, cccae_model):
    # (segment − 1 + context) frames at 100 fps + the features' reach beyond a frame's start
    assert mfcc_model.stream().latency_ms == pytest.approx(490 + 250 + (4 * 160 + 280) / 16)  # 797.5 ms
    assert cccae_model.stream().latency_ms == pytest.approx(490 + 250 + (280 + 160) / 16)      # 767.5 ms
    assert mfcc_model.can_stream and not mfcc_model.causal


def test_frames_come_out_as_soon_as_the_lookahead_allows(mfcc_model):
    """A frame is emitted exactly when the audio reaches its time + latency (first frame of a block)."""
    st = mfcc_model.stream(seed=0)
    lat = int(round(st.latency_ms * 16))  # samples
    rng = np.random.default_rng(0)
    x = (0.1 * rng.standard_normal(lat + 25 * 160)).astype(np.float32)
    assert len(st.push(x[: lat - 1])) == 0
    assert len(st.push(x[lat - 1: lat])) == 25           # frames 0..24 final at 797.5 ms
    assert len(st.push(x[lat: lat + 25 * 160 - 1])) == 0
    assert len(st.push(x[lat + 25 * 160 - 1:])) == 25


def test_paper_params_stream_equals_the_paper_pipeline(mfcc_model, corpus):
    from headmotion.models import nets
    from headmotion.systems.dnn import PAPER_PARAMS

    m = mfcc_model
    m.set_params(**PAPER_PARAMS)
    audio = _speech_with_pause(corpus)
    got = m.predict(audio).rotvec
    feats = m._extract(audio, len(got))
    y = nets.predict_regressor(m.regressor_, np.asarray(m.feature_norm_.transform(feats), dtype=np.float32))
    y = nets.apply_postfilter(m.postfilter_, y, segment=int(m.segment))
    np.testing.assert_array_equal(got, np.asarray(m.motion_norm_.inverse_transform(y), dtype=np.float64))
    _, streamed = _streamed(m, np.asarray(audio.samples), [160], seed=0)
    assert np.abs(streamed - got).max() < TOL


def test_causal_post_is_chunk_invariant_and_centred_on_the_running_mean():
    rng = np.random.default_rng(4)
    y = rng.standard_normal((3000, 3)) + [2.0, -1.0, 0.5]
    gv = np.array([2.0, 3.0, 1.5])

    def run(sizes, share):
        p = dnn_post.CausalPost(gv=gv, share=share, sd=np.ones(3), fps=100.0, tau_s=4.0,
                                rng=np.random.default_rng(9))
        out, i, k = [], 0, 0
        while i < len(y):
            n = sizes[k % len(sizes)]
            out.append(p.push(y[i:i + n]))
            i, k = i + n, k + 1
        return np.concatenate(out)

    whole = run([len(y)], 0.0)
    c = np.cumsum(y, axis=0) / np.arange(1, len(y) + 1)[:, None]
    np.testing.assert_allclose(whole, c + gv * (y - c), atol=1e-12)     # the known answer
    for share in (0.0, 0.15):
        np.testing.assert_array_equal(run([7, 160, 1], share), run([len(y)], share))
    # the drift's OU part has unit variance and the time constant given (a long run)
    p = dnn_post.CausalPost(share=0.5, sd=np.ones(1), fps=100.0, tau_s=2.0, rng=np.random.default_rng(1))
    z = p.push(np.zeros((200_000, 1))) / np.sqrt(0.5)
    assert z.std() == pytest.approx(1.0, abs=0.05)


def test_stream_command_with_a_file(mfcc_model, corpus, tmp_path):
    from typer.testing import CliRunner

    from headmotion.cli import app
    from headmotion.io import save_audio

    m = mfcc_model
    m.set_params(variance_restore=True, drift_share=0.15, drift_tau_s=4.0, idle=0.4, seed=0)
    path = m.save(tmp_path / "mfcc.hmz")
    audio = _speech_with_pause(corpus)
    wav = tmp_path / "speech.wav"
    save_audio(audio, wav, subtype="FLOAT")
    res = CliRunner().invoke(app, ["stream", "-m", str(path), "--input", str(wav), "--seed", "2"])
    assert res.exit_code == 0, res.output
    lines = [json.loads(s) for s in res.stdout.splitlines() if s.startswith("{")]
    off = m.predict(audio, seed=2).rotvec
    assert len(lines) == len(off)
    assert [r["frame"] for r in lines] == list(range(len(off)))
    got = np.array([r["rotvec"] for r in lines])
    assert np.abs(got - off).max() < 1e-3  # JSON rounding
