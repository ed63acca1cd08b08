"""The ruler for voices unlike the corpus: source-disjoint folds, degraded copies of speech and the
coupling of a model's motion to speech that has no recorded head."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.corpus import Corpus, Recording
from headmotion.errors import FormatError, ParameterError
from headmotion.evaluation.protocol.degraded import add_noise, degrade, gain, mp3, telephone
from headmotion.evaluation.protocol.folds import make_folds
from headmotion.systems.base import Synthesizer
from headmotion.types import Audio, Motion

SR = 16000


def tone(hz: float, seconds: float = 1.0, amp: float = 0.3) -> Audio:
    t = np.arange(int(seconds * SR)) / SR
    return Audio((amp * np.sin(2 * np.pi * hz * t)).astype(np.float32), SR)


def level_db(x) -> float:
    x = np.asarray(x, dtype=float)
    return 10 * np.log10(np.mean(x * x))


# -- degraded copies ---------------------------------------------------------------------------------
def test_noise_is_at_the_asked_snr_and_seeded():
    a = tone(200.0, 2.0)
    b = add_noise(a, 20.0, seed=3)
    noise = b.samples.astype(float) - a.samples.astype(float)
    assert level_db(a.samples) - level_db(noise) == pytest.approx(20.0, abs=0.2)
    assert np.array_equal(b.samples, add_noise(a, 20.0, seed=3).samples)


def test_quiet_is_minus_20_db():
    a = tone(200.0)
    assert np.allclose(gain(a, -20.0).samples, a.samples * 0.1, atol=1e-7)


def test_telephone_keeps_the_voice_band_and_cuts_below_it():
    mid, low = telephone(tone(1000.0, 2.0)), telephone(tone(100.0, 2.0))
    inner = slice(SR // 2, -SR // 2)  # away from the filter's start
    assert level_db(mid.samples[inner]) == pytest.approx(level_db(tone(1000.0, 2.0).samples), abs=1.0)
    assert level_db(tone(100.0).samples) - level_db(low.samples[inner]) > 20.0
    assert len(mid.samples) == 2 * SR


def test_mp3_round_trip_is_aligned_and_close():
    a = tone(440.0, 2.0)
    b = mp3(a, bitrate=64000)
    assert len(b.samples) == len(a.samples) and b.sample_rate == SR
    x, y = a.samples[SR // 4:-SR // 4].astype(float), b.samples[SR // 4:-SR // 4].astype(float)
    assert np.corrcoef(x, y)[0, 1] > 0.99


def test_unknown_degradation_is_named():
    with pytest.raises(ParameterError, match="unknown degradation 'radio'"):
        degrade(tone(200.0), "radio")
    a = tone(200.0)
    assert degrade(a, "clean") is a


# -- source-disjoint folds -------------------------------------------------------------------------------
def _saved(tmp_path, sources) -> Corpus:
    """A corpus on disk whose recordings r0, r1, … come from ``sources`` (None: no source)."""
    import dataclasses

    recs = [Recording(f"r{i}", f"s{i}", "read", Audio(np.zeros(SR, np.float32), SR), Motion(np.zeros((25, 3)), 25.0))
            for i in range(len(sources))]
    Corpus(recs, sample_rate=SR).save(tmp_path)
    c = Corpus.load(tmp_path)
    Corpus(root=tmp_path, entries=[dataclasses.replace(e, source=s) for e, s in zip(c.entries, sources)]).save(tmp_path)
    return Corpus.load(tmp_path)


def test_sources_protocol_holds_out_each_source_whole(tmp_path):
    c = _saved(tmp_path, ["a", "a", "b", "c", "c"])
    assert [e.source for e in c.entries] == ["a", "a", "b", "c", "c"]  # the column written and read back
    folds = make_folds(c, "sources")
    assert [f[0] for f in folds] == ["a", "b", "c"]
    for name, train, test, others in folds:
        assert {e.source for e in test.entries} == {name}
        assert name not in {e.source for e in train.entries}
        assert len(train) + len(test) == 5 and others.ids == train.ids


def test_sources_protocol_needs_a_source_for_every_recording_and_two_sources(tmp_path):
    with pytest.raises(ParameterError, match="needs a 'source' for every recording.*'r1'"):
        make_folds(_saved(tmp_path / "x", ["a", None]), "sources")
    with pytest.raises(ParameterError, match="at least 2 sources"):
        make_folds(_saved(tmp_path / "y", ["a", "a"]), "sources")
    _saved(tmp_path / "z", [None])  # a corpus without sources writes no source column
    assert "source" not in (tmp_path / "z" / "corpus.csv").read_text()


# -- coupling on speech with no recorded head -------------------------------------------------------------
class _Planted(Synthesizer):
    """Makes the planted head of the speech it is given (tied to its loudness) or, with
    ``other``, the planted head of unrelated speech (no tie)."""

    name = "planted-follower"

    def __init__(self, other: Audio | None = None):
        self.other = other
        self.fitted_ = True
        self.sample_rate_ = SR
        self.fps_ = 25.0
        self.mean_pose_ = np.zeros(3)

    def fit(self, corpus, *, progress=None):
        return self

    def _get_state(self):
        return {}, {}

    def _set_state(self, config, arrays):
        pass

    def _predict(self, audio, *, seed):
        from headmotion.synthetic import planted_motion

        m = planted_motion(audio if self.other is None else self.other, fps=25.0, seed=int(seed))
        n = int(len(audio.samples) / audio.sample_rate * 25)
        return Motion(np.resize(m.rotvec, (n, 3)) if self.other is not None else m.rotvec[:n], 25.0)


@pytest.fixture(scope="module")
def planted():
    from headmotion.synthetic import planted_corpus

    return planted_corpus(minutes=2.0, n_recordings=4, fps=25.0, seed=1)


def test_a_model_tied_to_its_speech_is_found_and_an_untied_one_is_not(planted):
    from headmotion.evaluation.protocol.speech_only import fit_projections, pooled_table, speech_coupling

    speech = {f"take{i}": planted[i].audio for i in range(3)}
    other = planted[3].audio
    cca = fit_projections(planted)
    rows = speech_coupling(None, {"tied": _Planted(), "untied": _Planted(other)}, speech, seeds=[0, 1],
                           degradations=("clean", "quiet"), n_shifts=50, projections=cca)
    pooled = {(r["degradation"], r["system"], r["seed"]): r for r in rows if r["file"] == "ALL"}
    for deg in ("clean", "quiet"):  # the planted head follows loudness relative to the file: -20 dB changes nothing
        assert pooled[(deg, "tied", "ALL")]["p"] < 0.01 and pooled[(deg, "tied", "ALL")]["excess"] > 0.2
        assert pooled[(deg, "untied", "ALL")]["p"] > 0.05
    assert len([r for r in rows if r["file"] != "ALL"]) == 2 * 2 * 2 * 3
    table = pooled_table(rows)
    assert "| clean | tied |" in table and "seed 1: excess (p)" in table


def test_cli_parses_seeds_and_finds_speech(tmp_path):
    from headmotion.cli.speech_eval_cmds import parse_seeds, speech_files

    assert parse_seeds("0-3") == [0, 1, 2, 3] and parse_seeds("1,4, 7") == [1, 4, 7]
    for bad in ("3-1", "x", "-2", ""):
        with pytest.raises(ParameterError, match="--seeds"):
            parse_seeds(bad)
    (tmp_path / "sub").mkdir()
    for name in ("b.wav", "sub/a.flac", "notes.txt"):
        (tmp_path / name).write_bytes(b"")
    assert [p.name for p in speech_files([tmp_path])] == ["b.wav", "a.flac"]
    (tmp_path / "empty").mkdir()
    with pytest.raises(FormatError, match="no audio file"):
        speech_files([tmp_path / "empty"])
    with pytest.raises(FormatError, match="no such file"):
        speech_files([tmp_path / "missing.wav"])
