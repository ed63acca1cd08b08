"""``amount``: how much the head moves, by the choice of recorded movements — 1 is the model as it
is, larger chooses clips that move more, smaller calmer ones, 0 holds the mean pose; the stream
equals predict at any amount; the range is checked once for every front end (planted corpus)."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.rotations import rotvec_to_pitch_yaw_roll
from headmotion.synthesis import AMOUNT_RANGE, Controls, open_stream, synthesize
from headmotion.systems import create


@pytest.fixture(scope="module")
def corpus(planted):
    return planted(minutes=1.5, n_recordings=3, seed=11)


@pytest.fixture(scope="module")
def model(corpus):
    return create("motion-match", prosody="f0e-live").fit(corpus)


def angles(motion):
    return np.degrees(rotvec_to_pitch_yaw_roll(motion.rotvec))


def test_amount_one_is_the_model_as_it_is(model, corpus):
    audio = corpus[0].audio.slice_seconds(0, 15.0)
    plain = synthesize(audio, model, seed=2)[0]
    one = synthesize(audio, model, seed=2, amount=1.0)[0]
    np.testing.assert_array_equal(plain.rotvec, one.rotvec)
    assert model.amount == 1.0  # the caller's model is left as it was


def test_amount_zero_holds_the_mean_pose(model, corpus):
    m = synthesize(corpus[1].audio, model, seed=0, amount=0)[0]
    np.testing.assert_allclose(m.rotvec, np.repeat(m.rotvec[:1], len(m), 0), atol=1e-12)
    np.testing.assert_allclose(angles(m)[0], np.degrees(model.mean_pose_), atol=1e-9)  # (pitch, yaw, roll)


def test_more_amount_chooses_more_motion_less_chooses_calmer(model, corpus):
    """Averaged over recordings and seeds, the SD of the motion rises with the amount, and the
    frame-to-frame speed with it (the lean is to clips that move more over the next hop)."""
    def sd_and_speed(a):
        sd, sp = [], []
        for r in corpus:
            for s in (0, 1):
                x = angles(synthesize(r.audio, model, seed=s, amount=a)[0])
                sd.append(x.std(axis=0).mean())
                sp.append(np.abs(np.diff(x, axis=0)).mean())
        return np.mean(sd), np.mean(sp)

    (sd_lo, sp_lo), (sd_1, sp_1), (sd_hi, sp_hi) = (sd_and_speed(a) for a in (0.5, 1.0, 2.5))
    assert sd_lo < sd_1 < sd_hi and sp_lo < sp_1 < sp_hi


def test_the_stream_equals_predict_at_any_amount(model, corpus):
    audio = corpus[2].audio.slice_seconds(0, 12.0)
    whole = synthesize(audio, model, seed=5, amount=2.0)[0]
    s = open_stream(model, seed=5, amount=2.0)
    x = audio.samples.astype(np.float32)
    parts = [s.push(x[i:i + 1234]) for i in range(0, len(x), 1234)] + [s.flush()]
    streamed = np.vstack([np.asarray(p.rotvec).reshape(-1, 3) for p in parts])
    np.testing.assert_allclose(streamed, whole.rotvec, atol=1e-9)


@pytest.mark.parametrize("bad", [-0.1, AMOUNT_RANGE[1] + 0.5, float("nan"), "2", True])
def test_out_of_range_amounts_are_refused_with_the_range(bad):
    with pytest.raises(ParameterError, match=r"amount \(--amount\) must be a number from 0 to 3"):
        Controls(amount=bad)


def test_a_model_that_does_not_choose_movements_refuses_an_amount(corpus):
    tws = create("tws-basic").fit(corpus)
    with pytest.raises(ParameterError, match="--gain"):
        synthesize(corpus[0].audio, tws, amount=2.0)
    synthesize(corpus[0].audio.slice_seconds(0, 3.0), tws, amount=1.0)  # the natural amount is every model's


def test_the_model_parameter_is_checked_too(model):
    m = create("motion-match", amount=7)
    with pytest.raises(ParameterError, match="'amount' parameter of motion-match must be a number from 0 to 3"):
        m._validate_params()
