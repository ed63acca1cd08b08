"""``loudness-wobble``: the robot app's loudness-scaled sine wobble as a baseline — known answers on
constructed signals (levels, gate, amplitude, frequencies), seeds and a model file round trip."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.corpus import Corpus, Recording
from headmotion.systems.base import create, load_model
from headmotion.systems.loudness_wobble import envelope, step_levels
from headmotion.types import Audio, Motion

SR = 16000


def tone(seconds: float, db: float, hz: float = 200.0) -> np.ndarray:
    t = np.arange(int(seconds * SR)) / SR
    return (np.sqrt(2) * 10 ** (db / 20) * np.sin(2 * np.pi * hz * t)).astype(np.float32)


@pytest.fixture(scope="module")
def model():
    n = 250
    rv = np.tile([0.05, 0.0, 0.0], (n, 1))  # a recorded head 2.86 degrees nose down throughout
    rec = Recording.aligned("r", "s", "t", Audio(tone(10.0, -20.0), SR), Motion(rv, 25.0))
    return create("loudness-wobble").fit(Corpus([rec]))


def test_levels_are_the_last_20_ms_in_db():
    x = np.concatenate([tone(0.5, -20.0), np.zeros(SR // 2, np.float32)])
    lv = step_levels(x, SR)
    assert len(lv) == 20 and np.allclose(lv[:10], -20.0, atol=0.1) and np.all(lv[11:] < -100)


def test_the_gate_opens_at_minus_35_and_closes_after_250_ms_below_minus_45():
    # between the thresholds from the start the gate stays shut: the envelope only runs the release
    # ramp that the rule starts from (0.8 of the way, followed at 0.65) down to nothing
    shut = envelope(np.full(10, -40.0))
    assert shut[0] == pytest.approx(0.52) and shut.max() < 0.6 and shut[-1] < 1e-3
    env = envelope(np.concatenate([np.full(20, -20.0), np.full(20, -60.0)]))
    assert env[0] == pytest.approx(0.65) and env[19] == pytest.approx(1.0)
    assert np.allclose(env[20:24], 1.0)                          # held for 250 ms below -45 dB ...
    assert 0.05 < env[27] < 0.9 and env[30] < 0.05 and env[-1] < 1e-3  # ... then ramped down over five steps


def test_silence_is_the_mean_pose(model):
    m = model.predict(Audio(np.zeros(3 * SR, np.float32), SR), seed=1)
    assert len(m) == 75
    np.testing.assert_allclose(m.as_pitch_yaw_roll(degrees=True), [[np.degrees(0.05), 0.0, 0.0]] * 75, atol=1e-9)


def test_a_loud_voice_wobbles_at_the_rules_frequencies_and_amplitudes(model):
    m = model.predict(Audio(tone(20.0, -10.0), SR), seed=3)
    pyr = m.as_pitch_yaw_roll(degrees=True)[25:] - np.array([np.degrees(0.05), 0.0, 0.0])
    f = np.fft.rfftfreq(len(pyr), 1 / 25.0)
    for axis, (hz, deg) in enumerate(((2.2, 4.5), (0.6, 7.5), (1.3, 2.25))):
        spec = np.abs(np.fft.rfft(pyr[:, axis]))
        assert abs(f[np.argmax(spec)] - hz) < 0.1
        # full loudness (-10 dB + 4 is above -18): the amplitude times the master gain 1.5
        assert np.abs(pyr[:, axis]).max() == pytest.approx(1.5 * deg, rel=0.1)


def test_seeds_draw_the_phases_and_the_model_file_keeps_it(model, tmp_path):
    a = Audio(tone(4.0, -15.0), SR)
    one, again, other = (model.predict(a, seed=s).rotvec for s in (1, 1, 2))
    np.testing.assert_array_equal(one, again)
    assert np.abs(one - other).max() > 0.01
    loaded = load_model(model.save(tmp_path / "wobble.hmz"))
    np.testing.assert_array_equal(loaded.predict(a, seed=1).rotvec, one)
