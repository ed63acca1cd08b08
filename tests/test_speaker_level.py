"""Pitch and level relative to the voice so far (headmotion.features.speaker_level): known answers
for the running level and its prior, unvoiced frames leaving it alone, a whole file equal to the
stream's rows, and a motion-match model reading it whose stream equals ``predict``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.features.readers import f0e_stream
from headmotion.features.speaker_level import PRIOR_ENERGY_DB, PRIOR_LOGF0, SpeakerLevel
from headmotion.systems.base import create

FPS = 25.0


class _Rows:
    """An extractor stand-in that gives the rows it is pushed."""

    names = ["energy", "d_energy", "logf0", "d_logf0", "voiced"]
    fps = FPS
    latency_ms = 39.0

    def push(self, rows):
        return np.asarray(rows, dtype=np.float64).reshape(-1, 5)

    def flush(self):
        return np.zeros((0, 5))


def _row(logf0, energy, voiced=1.0, d=0.5):
    return [energy, d, logf0, d, voiced]


def test_a_steady_voice_is_read_at_the_prior_level_once_it_has_spoken():
    lf, e = math.log(220.0), -18.0
    sl = SpeakerLevel(_Rows(), half_life_s=10.0, prior_s=1.0)
    out = sl.push([_row(lf, e)] * 1000)  # 40 s of voiced speech
    w0 = 1.0 * FPS  # the prior is worth a second of voiced speech
    first_level = (lf + w0 * PRIOR_LOGF0) / (1 + w0)
    assert out[0, 2] == pytest.approx(lf - first_level + PRIOR_LOGF0)
    d = 0.5 ** (1 / (10.0 * FPS))
    w = (1 - d ** 1000) / (1 - d)  # the voiced frames' decayed weight after 40 s
    for col, x, prior in ((2, lf, PRIOR_LOGF0), (0, e, PRIOR_ENERGY_DB)):
        level = (w * x + w0 * prior) / (w + w0)
        assert out[-1, col] == pytest.approx(x - level + prior)
        assert abs(out[-1, col] - prior) < 0.07 * abs(x - prior)  # near the prior: the voice's own level
    np.testing.assert_array_equal(out[:, [1, 3, 4]], np.tile([0.5, 0.5, 1.0], (1000, 1)))  # deltas, voicing kept


def test_unvoiced_frames_leave_the_level_and_a_new_voice_moves_it():
    sl = SpeakerLevel(_Rows(), half_life_s=2.0, prior_s=0.0)
    a = sl.push([_row(5.0, -20.0)] * 50)
    quiet = sl.push([_row(9.0, -80.0, voiced=0.0)] * 50)  # a pause: held pitch, silence
    assert a[-1, 2] == pytest.approx(PRIOR_LOGF0)
    np.testing.assert_allclose(quiet[:, 2], 9.0 - 5.0 + PRIOR_LOGF0)  # shifted by the voice's level, unchanged
    b = sl.push([_row(4.5, -30.0)] * 500)  # a lower, quieter voice: 20 s, ten half-lives
    assert b[0, 2] < PRIOR_LOGF0 - 0.45  # at first read against the former voice's level: low
    assert b[-1, 2] == pytest.approx(PRIOR_LOGF0, abs=1e-3)
    assert b[-1, 0] == pytest.approx(PRIOR_ENERGY_DB, abs=1e-2)


def test_a_whole_file_equals_the_streams_rows():
    import soundfile as sf

    x, sr = sf.read(Path(__file__).resolve().parents[1] / "examples" / "speech" / "short.wav", dtype="float32")
    assert sr == 16000
    whole = f0e_stream(fps=FPS, voicing=True, speaker_half_life_s=5.0)
    want = np.vstack([whole.push(x), whole.flush()])
    st = f0e_stream(fps=FPS, voicing=True, speaker_half_life_s=5.0)
    got = np.vstack([st.push(x[i:i + 333]) for i in range(0, len(x), 333)] + [st.flush()])
    np.testing.assert_array_equal(got, want)
    plain = f0e_stream(fps=FPS, voicing=True)
    raw = np.vstack([plain.push(x), plain.flush()])
    names = list(plain.names)
    shifted = [names.index("logf0"), names.index("energy")]
    kept = [i for i in range(len(names)) if i not in shifted]
    assert raw[:, -1].any() and not np.array_equal(raw[:, shifted], want[:, shifted])
    np.testing.assert_array_equal(raw[:, kept], want[:, kept])  # the deltas and voicing as read


def test_it_needs_the_columns_and_a_half_life():
    class NoVoicing(_Rows):
        names = ["energy", "d_energy", "logf0", "d_logf0"]

    with pytest.raises(ParameterError, match="voiced"):
        SpeakerLevel(NoVoicing(), half_life_s=5.0)
    with pytest.raises(ParameterError, match="half_life_s"):
        SpeakerLevel(_Rows(), half_life_s=0.0)


@pytest.fixture(scope="module")
def corpus(planted):
    return planted(minutes=1.5, n_recordings=3, seed=11)


@pytest.mark.parametrize("live", [False, True])
def test_a_model_reading_relative_to_the_voice_streams_as_it_predicts(corpus, live):
    m = create("motion-match", prosody="f0e-live", live=live, hop=4 if live else 15, speaker_s=10.0).fit(corpus)
    audio = corpus[1].audio.slice_seconds(0, 8.0)
    out = m.predict(audio, seed=3)
    st = m.stream(seed=3)
    x = audio.samples
    parts = [st.push(x[i:i + 480]) for i in range(0, len(x), 480)] + [st.flush()]
    np.testing.assert_array_equal(np.concatenate([p.rotvec for p in parts]), out.rotvec)
    plain = create("motion-match", prosody="f0e-live", live=live, hop=4 if live else 15).fit(corpus)
    assert not np.array_equal(plain.lib_feats_, m.lib_feats_)
    with pytest.raises(ParameterError, match="speaker_s"):
        create("motion-match", prosody="f0e", speaker_s=10.0).fit(corpus)
