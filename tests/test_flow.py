"""motion-flow: seeded sampling, distinct takes, persistence, and windows that join without seams
(tiny settings on the planted corpus; the contract checks are in test_contract.py)."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.rotations import rotvec_to_pitch_yaw_roll
from headmotion.systems import create, load_model
from headmotion.systems.flow import WindowSampler, speaker_split

TINY = dict(window=24, prefix=6, hidden=16, n_blocks=3, train_steps=250, batch_size=16, eval_every=50,
            sampling_steps=4, n_threads=1)


@pytest.fixture(scope="module")
def corpus(planted):
    return planted(minutes=1.5, n_recordings=3, seed=11)


@pytest.fixture(scope="module")
def model(corpus):
    return create("motion-flow", **TINY).fit(corpus)


def angles(motion):
    return np.degrees(rotvec_to_pitch_yaw_roll(motion.rotvec))


def test_same_seed_same_motion_other_seed_other_take(model, corpus):
    audio = corpus[2].audio.slice_seconds(0, 8.0)
    a, b, c = (angles(model.predict(audio, seed=s)) for s in (3, 3, 4))
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    # a different take, not the same path with an offset: the paths are far from perfectly correlated
    assert max(abs(np.corrcoef(a[:, k], c[:, k])[0, 1]) for k in range(3)) < 0.9
    # the default seed is the ``seed`` parameter
    np.testing.assert_array_equal(angles(model.predict(audio)), angles(model.predict(audio, seed=model.seed)))


def test_save_load_gives_identical_motion(model, corpus, tmp_path):
    audio = corpus[1].audio.slice_seconds(0, 5.0)
    back = load_model(model.save(tmp_path / "flow.hmz"))
    np.testing.assert_array_equal(back.predict(audio, seed=2).rotvec, model.predict(audio, seed=2).rotvec)
    assert back.get_params() == model.get_params()


def test_models_saved_before_the_join_parameters_sample_as_they_did(model):
    """A saved state without ``target``, ``join_frames`` and ``inpaint`` (older models) is the
    velocity network with the prefix only held, not the joined windows of today's defaults."""
    config, arrays = model._get_state()
    params = {k: v for k, v in config["params"].items() if k not in ("target", "join_frames", "inpaint")}
    old = type(model)()
    old._set_state({**config, "params": params}, arrays)
    assert (old.target, old.join_frames, old.inpaint) == ("velocity", 0, "hold")
    assert (type(model)().target, type(model)().join_frames) == ("velocity", 8)


def test_windows_continue_what_came_before(model, corpus):
    """A long input's first window is the window made from those frames alone (a later window never
    changes frames already made), and any length works, shorter than one window included."""
    feats = model._features(corpus[0].audio, 200)
    long = model.generate(feats, seed=5)
    first = model.generate(feats[:model.window], seed=5)
    np.testing.assert_array_equal(long[:model.window], first)
    for n in (1, 7, model.window + 1, 3 * model.window - 5):
        assert model.generate(feats[:n], seed=5).shape == (n, 3)


def test_no_jump_where_windows_join(model, corpus):
    """Frame-to-frame steps where a window takes over from the previous one are no larger than the
    steps inside windows."""
    x = model.generate(model._features(corpus[0].audio, 400), seed=1)
    step = np.abs(np.diff(x, axis=0)).max(axis=1)
    W, P = model.window, model.prefix
    joins = np.arange(W - 1, len(x) - 1, W - P)[:-1]   # the last frame of each known prefix
    inside = np.delete(step, joins)
    assert step[joins].max() <= 2.0 * np.quantile(inside, 0.95), (step[joins], np.quantile(inside, 0.95))


def test_join_offsets_carry_a_window_on_from_its_prefix():
    """The first free frame continues the prefix at its last step; the offset fades out after
    ``join_frames`` frames; a window without a prefix is left alone."""
    import torch

    from headmotion.models.flow_net import join_offsets

    W, P = 30, 10
    prefix = torch.zeros(2, 3, W)
    prefix[:, :, :P] = 0.1 * torch.arange(P, dtype=torch.float32)
    mask = torch.zeros(2, 1, W)
    mask[0, 0, :P] = 1.0
    clean = torch.full((2, 3, W), 5.0)
    out = clean + join_offsets(prefix, mask, clean, 4)
    np.testing.assert_allclose(out[0, :, P].numpy(), 1.0, atol=1e-5)
    np.testing.assert_allclose(out[0, :, P + 4:].numpy(), 5.0)
    assert (np.diff(out[0, 0, P:P + 5].numpy()) > 0).all()
    np.testing.assert_array_equal(out[1].numpy(), clean[1].numpy())


def test_replacement_inpainting_changes_only_windows_that_continue_a_prefix(model, corpus):
    feats = model._features(corpus[0].audio, 60)
    held = model.generate(feats, seed=2)
    other = model.set_params(inpaint="replace").generate(feats, seed=2)
    model.set_params(inpaint="hold")
    np.testing.assert_array_equal(other[:model.window], held[:model.window])
    assert other.shape == held.shape and not np.allclose(other, held)


def test_speaker_split_keeps_speakers_whole(planted):
    c = planted(minutes=0.6, n_recordings=2, speakers=("a", "b", "c", "d"), seed=2)
    held = speaker_split(list(c), 0.3, seed=0)
    spk_held = {r.speaker for r, h in zip(c, held) if h}
    spk_train = {r.speaker for r, h in zip(c, held) if not h}
    assert spk_held and spk_train and not spk_held & spk_train
    assert not speaker_split(list(c)[:1], 0.3, seed=0).any()


def test_window_sampler_pads_short_recordings_and_mirrors_jointly():
    rng = np.random.default_rng(0)
    m = np.tile(np.array([[1.0, 2.0, 3.0]], np.float32), (10, 1))
    f = np.zeros((10, 2), np.float32)
    mot, cond, valid = WindowSampler([(m, f)], 16, augment=False).batch(rng, 2)
    assert valid[:, 0, :10].all() and not valid[:, 0, 10:].any()
    np.testing.assert_array_equal(mot[0, :, 0], [1.0, 2.0, 3.0])
    mot, _, _ = WindowSampler([(m, f)], 16, augment=True).batch(rng, 64)
    signs = np.sign(mot[:, :, 0])
    assert (signs[:, 0] > 0).all() and (signs[:, 1] == signs[:, 2]).all() and (signs[:, 1] < 0).any()


@pytest.mark.parametrize("bad", [dict(prefix=12), dict(window=4), dict(guidance=-1.0), dict(device="tpu"),
                                 dict(cond_dropout=1.0), dict(sampling_steps=0), dict(target="noise"),
                                 dict(join_frames=-1), dict(inpaint="blend")])
def test_bad_parameters_are_refused(bad, corpus):
    with pytest.raises(ParameterError):
        create("motion-flow", **{**TINY, **bad}).fit(corpus)


def test_cuda_request_without_cuda_is_a_clear_error(corpus):
    import torch

    if torch.cuda.is_available():
        pytest.skip("a CUDA device is present")
    with pytest.raises(ParameterError, match="CUDA"):
        create("motion-flow", **{**TINY, "device": "cuda"}).fit(corpus)
