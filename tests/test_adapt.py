"""Adapting a motion-match model to a speaker: the speaker's own recordings join the base's library
and are preferred — a known answer (their own speech plays their recorded motion back, whatever the
base holds) — the model keeps its base, saves and loads, and too little material, a mismatched
pair or a base that does not match movements get one clear error and no file (planted corpus)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from typer.testing import CliRunner

from headmotion.cli import app
from headmotion.corpus import Corpus, Recording
from headmotion.errors import ParameterError
from headmotion.rotations import rotvec_to_pitch_yaw_roll
from headmotion.systems import create, load_model
from headmotion.systems.adapt import adapt
from headmotion.motion.angles import centred_degrees
from headmotion.types import Motion

#: a base that plays back what it matches: nearest match only, leaving a clip costly, speech and
#: continuity only
PLAYBACK = dict(prosody="f0e-live", mirror=False, top_k=1, switch_cost=100.0, pause_switch=1.0, target_weight=0.0,
                pause_weight=0.0)


@pytest.fixture(scope="module")
def corpus(planted):
    return planted(minutes=2.0, n_recordings=2, speakers=("a", "b"), seed=5)


def speaker(corpus, name):
    return corpus.subset([i for i, r in enumerate(corpus) if r.speaker == name])


@pytest.fixture(scope="module")
def base(corpus):
    return create("motion-match", **PLAYBACK).fit(speaker(corpus, "a"))


def angles(motion):
    return np.degrees(rotvec_to_pitch_yaw_roll(motion.rotvec))


def test_the_speakers_own_speech_plays_their_recorded_motion_back(corpus, base):
    """With the speaker's take in the library and the base's frames costly, the take's own speech
    continues the take's clip from its first frame: the output is the recorded motion about the
    speaker's mean pose, although the base library is there too."""
    own = speaker(corpus, "b").subset([0])
    m = adapt(own, base, base_cost=1000.0, min_speech_s=0)
    assert len(m.lib_lengths_) == len(base.lib_lengths_) + 1 and m.lib_own_.tolist()[-1]
    rec = own[0]
    out = angles(m.predict(rec.audio, seed=0))
    truth = centred_degrees(rec.motion, len(out), 25.0)
    np.testing.assert_allclose(out - np.degrees(m.mean_pose_), truth, atol=1e-6)


def test_range_and_posture_follow_the_speaker(corpus, base):
    """A speaker who moves three times as much about another posture: the adapted model's mean pose
    is theirs and its motion moves more than the base's."""
    b = speaker(corpus, "b")
    tilt = np.array([0.1, 0.0, 0.05])
    big = Corpus([dataclasses.replace(r, motion=Motion(3.0 * (r.motion.rotvec - r.motion.rotvec.mean(0)) + tilt,
                                                          r.motion.fps)) for r in b], sample_rate=b.sample_rate)
    m = adapt(big, base.set_params(top_k=8, switch_cost=3.0), min_speech_s=0)
    base.set_params(**PLAYBACK)
    np.testing.assert_allclose(m.mean_pose_, tilt, atol=0.02)
    audio = corpus[0].audio
    assert angles(m.predict(audio, seed=1)).std(axis=0).mean() > 1.5 * angles(base.predict(audio, seed=1)).std(axis=0).mean()


def test_saved_and_loaded_it_says_what_it_was_adapted_from(corpus, base, tmp_path):
    m = adapt(speaker(corpus, "b"), base, min_speech_s=0)
    path = m.save(tmp_path / "mine.hmz")
    again = load_model(path)
    audio = corpus[3].audio.slice_seconds(0, 10.0)
    np.testing.assert_array_equal(again.predict(audio, seed=4).rotvec, m.predict(audio, seed=4).rotvec)
    assert again.adapted_from_["speech_seconds"] > 0 and again.adapted_from_["base_cost"] == 2.0
    assert again.lib_own_.sum() == 2


def test_the_registered_system_adapts_on_its_training_corpus(corpus, base, tmp_path):
    path = base.save(tmp_path / "base.hmz")
    sys_ = create("adapt", base=str(path), min_speech_s=0).fit(speaker(corpus, "b"))
    direct = adapt(speaker(corpus, "b"), str(path), min_speech_s=0)
    audio = corpus[0].audio.slice_seconds(0, 8.0)
    np.testing.assert_array_equal(sys_.predict(audio, seed=3).rotvec, direct.predict(audio, seed=3).rotvec)


def test_too_little_speech_is_refused(corpus, base):
    r = corpus[2]
    short = Corpus([Recording.aligned(r.id, r.speaker, r.task, r.audio.slice_seconds(0, 8.0),
                                      r.motion.slice_seconds(0, 8.0) if hasattr(r.motion, "slice_seconds")
                                      else Motion(r.motion.rotvec[: int(8 * r.motion.fps)], r.motion.fps))],
                   sample_rate=corpus.sample_rate)
    with pytest.raises(ParameterError, match=r"s of speech with motion; adapting needs at least 20 s"):
        adapt(short, base)


def test_a_mismatched_pair_is_refused(corpus, base):
    r = corpus[2]
    half = Motion(r.motion.rotvec[: len(r.motion) // 2], r.motion.fps)
    bad = Corpus([dataclasses.replace(r, motion=half)], sample_rate=corpus.sample_rate)
    with pytest.raises(ParameterError, match=rf"recording '{r.id}': its audio is .* but its motion"):
        adapt(bad, base, min_speech_s=0)


def test_a_base_that_does_not_match_movements_is_refused(corpus):
    tws = create("tws-basic").fit(speaker(corpus, "a"))
    with pytest.raises(ParameterError, match="adapting needs a motion-match model"):
        adapt(speaker(corpus, "b"), tws, min_speech_s=0)


def test_the_command_writes_the_model_and_its_card_or_nothing(corpus, base, tmp_path):
    folder = tmp_path / "spk"
    speaker(corpus, "b").save(folder)
    path = base.save(tmp_path / "base.hmz")
    runner = CliRunner()
    ok = runner.invoke(app, ["adapt", str(folder), "-o", str(tmp_path / "mine.hmz"), "--base", str(path)])
    assert ok.exit_code == 0, ok.output
    assert (tmp_path / "mine.hmz").is_file() and "Adapted from" in (tmp_path / "mine.md").read_text()
    assert "adapted" in runner.invoke(app, ["info", str(tmp_path / "mine.hmz")]).output
    tws = create("tws-basic").fit(speaker(corpus, "a")).save(tmp_path / "tws.hmz")
    bad = runner.invoke(app, ["adapt", str(folder), "-o", str(tmp_path / "x.hmz"), "--base", str(tws)])
    assert bad.exit_code != 0 and "needs a motion-match model" in bad.output + str(bad.exception)
    assert not (tmp_path / "x.hmz").exists() and not (tmp_path / "x.md").exists()


def test_the_adapted_model_keeps_the_bases_settings_unless_told(corpus, base):
    m = adapt(speaker(corpus, "b"), base, min_speech_s=0)
    assert {k: v for k, v in m.get_params().items() if k != "base_cost"} == \
        {k: v for k, v in base.get_params().items() if k != "base_cost"}
    assert adapt(speaker(corpus, "b"), base, min_speech_s=0, repeat_cost=3.0).repeat_cost == 3.0


def test_the_command_takes_audio_and_motion_files_paired_by_stem(corpus, base, tmp_path):
    folder = tmp_path / "spk"
    speaker(corpus, "b").save(folder)
    saved = Corpus.load(folder)
    files = [p for e in saved.entries for p in (folder / e.audio, folder / e.motion)]
    path = base.save(tmp_path / "base.hmz")
    runner = CliRunner()
    ok = runner.invoke(app, ["adapt", *map(str, files), "-o", str(tmp_path / "f.hmz"), "--base", str(path),
                             "--speaker", "bee"])
    assert ok.exit_code == 0, ok.output
    from_folder = adapt(saved, str(path))
    audio = corpus[0].audio.slice_seconds(0, 6.0)
    np.testing.assert_array_equal(load_model(tmp_path / "f.hmz").predict(audio, seed=2).rotvec,
                                  from_folder.predict(audio, seed=2).rotvec)
    assert "bee" in (tmp_path / "f.md").read_text()
    lone = runner.invoke(app, ["adapt", str(files[0]), str(tmp_path / "other.bvh"), "-o", str(tmp_path / "g.hmz")])
    assert lone.exit_code != 0 and not (tmp_path / "g.hmz").exists()
