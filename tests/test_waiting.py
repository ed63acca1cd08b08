"""A head that waits: recorded pause speeds from known motions, and a model through silence — a held
head has speed 0 and no loop, a motion-match model that may repeat clips loops less with
``repeat_cost`` (planted corpus)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from headmotion.evaluation.measures.realism import speech_mask_for
from headmotion.evaluation.measures.waiting import pause_segment_speeds, waiting
from headmotion.motion.pauses import pause_mask
from headmotion.systems import create
from headmotion.types import Motion


@pytest.fixture(scope="module")
def corpus(planted):
    return planted(minutes=1.5, n_recordings=3, seed=11)


def test_a_head_still_in_its_pauses_has_pause_speeds_near_zero(corpus):
    """Motion that nods at 1 Hz while the speaker speaks and holds in every pause: each pause's mean
    speed is a small share of the speech's (the 6 Hz low-pass smears only the pause's edges)."""
    recs = []
    for r in corpus:
        m25 = r.motion.resample(25.0)
        mask = speech_mask_for(r.audio, m25)
        t = np.arange(len(mask)) / 25.0
        pitch = np.where(pause_mask(mask, fps=25.0), 0.0, 0.1 * np.sin(2 * np.pi * t))  # 0.1 rad at 1 Hz
        recs.append(dataclasses.replace(r, motion=Motion(np.c_[pitch, 0 * t, 0 * t], 25.0)))
    ps = pause_segment_speeds(recs)
    assert len(ps.segments) >= 3
    nod_speed = np.degrees(0.1) * 2 * np.pi * (2 / np.pi)  # mean |d/dt| of the nod, °/s (≈ 23)
    assert ps.ratio < 0.25 and np.median(ps.segments) < 0.25 * nod_speed


def test_a_held_head_waits_without_moving_and_without_a_loop(corpus):
    m = create("motion-match", prosody="f0e-live", amount=0.0).fit(corpus)
    w = waiting(m, seconds=6.0, seeds=(0, 1))
    np.testing.assert_allclose(w.speed, 0.0, atol=1e-9)
    np.testing.assert_allclose(w.loop, 0.0, atol=1e-9)
    assert np.isnan(w.ratio)  # no speech given: no ratio


def test_waiting_reports_a_ratio_to_the_models_speech_speed(corpus):
    m = create("motion-match", prosody="f0e-live").fit(corpus)
    w = waiting(m, seconds=6.0, seeds=(0,), speech=[corpus[0].audio])
    assert w.speed[0] > 0 and 0 < w.ratio < 5


def test_the_head_waits_only_once_the_pause_is_long(corpus):
    """``wait_s``: speech without a long pause, and the first ``wait_s`` seconds of a silence, are
    made exactly as without it; past that, the waiting costs choose other clips."""
    from headmotion.types import Audio

    plain = create("motion-match", prosody="f0e-live").fit(corpus)
    waits = create("motion-match", prosody="f0e-live", wait_s=2.0).fit(corpus)
    speech = corpus[0].audio.slice_seconds(0, 8.0)
    np.testing.assert_array_equal(plain.predict(speech, seed=1).rotvec, waits.predict(speech, seed=1).rotvec)
    silence = Audio(np.zeros(16000 * 12, np.float32), 16000)
    a, b = plain.predict(silence, seed=1).rotvec, waits.predict(silence, seed=1).rotvec
    np.testing.assert_array_equal(a[:50], b[:50])  # 2 s at 25 fps
    assert not np.array_equal(a, b)


def test_the_shipped_default_waits_without_a_loop():
    """On 20 s of silence the shipped default does not repeat one movement every decision: its loop
    index (the velocity autocorrelation's highest peak at 0.25–2 s) stays below the recorded heads'
    median (0.25 on the talking-video corpus), where without ``wait_s`` it is 0.45–0.67."""
    from headmotion.synthesis import load_model

    m = load_model("default")
    assert m.wait_s > 0
    w = waiting(m, seconds=20.0, seeds=(0, 1, 2, 3))
    assert w.loop.max() < 0.25 and 3.0 < w.speed.mean() < 15.0
