"""Rulers with a level: the coupling measure's three speech sides, the Praat-read library beside
every motion-match model, and the speech-only set with each file's kind (known answers on planted
data; the shared data only where it is there)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from headmotion.corpus import Corpus, Recording
from headmotion.errors import FormatError, ParameterError
from headmotion.evaluation.measures.speech_sides import (ENERGY_COLUMNS, F0E_COLUMNS, SPEECH_SIDES, parse_sides,
                                                         side_features, sides_features)
from headmotion.evaluation.protocol import levels as L
from headmotion.evaluation.protocol.speech_only import (files_table, fit_side_projections, pooled_table,
                                                        speech_coupling, speech_features)
from headmotion.systems.base import Synthesizer
from headmotion.types import Audio, Motion

FPS = 25.0
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def energy_head(audio: Audio, *, delay: int = 3, gain: float = 1.0, seed: int = 0) -> np.ndarray:
    """Rotation vectors whose yaw is the speech's loudness ``delay`` frames late (``gain`` of it),
    plus a small random walk on every axis."""
    from headmotion.align import n_frames
    from headmotion.synthetic import loudness

    n = n_frames(len(audio.samples), audio.sample_rate, FPS)
    e = loudness(audio, fps=FPS, n_frames=n)
    lagged = np.r_[np.full(delay, e[0]), e[:-delay]] if delay else e
    head = np.cumsum(np.random.default_rng(seed).normal(scale=0.002, size=(n, 3)), axis=0)
    head[:, 1] += gain * 0.1 * lagged
    return head


class _EnergyFollower(Synthesizer):
    """A head that is a delayed copy of the loudness of the speech it hears (``gain`` of it), or
    with ``other`` of unrelated speech (tied to nothing it hears)."""

    name = "energy-follower"

    def __init__(self, gain: float = 1.0, other: Audio | None = None):
        self.gain, self.other = gain, other
        self.fitted_, self.sample_rate_, self.fps_, self.mean_pose_ = True, 16000, FPS, np.zeros(3)

    def fit(self, corpus, *, progress=None):
        return self

    def _get_state(self):
        return {}, {}

    def _set_state(self, config, arrays):
        pass

    def _predict(self, audio, *, seed):
        n = int(len(audio.samples) / audio.sample_rate * FPS)
        if self.other is not None:
            return Motion(np.resize(energy_head(self.other, seed=int(seed)), (n, 3)), FPS)
        return Motion(energy_head(audio, gain=self.gain, seed=int(seed))[:n], FPS)


@pytest.fixture(scope="module")
def speech_corpus():
    """Speech of 6 recordings (tiled real speech) whose recorded heads follow their loudness."""
    from headmotion.synthetic import planted_corpus

    c = planted_corpus(minutes=2.0, n_recordings=6, fps=FPS, seed=2)
    return Corpus([Recording.aligned(r.id, r.speaker, r.task, r.audio, Motion(energy_head(r.audio, seed=i), FPS))
                   for i, r in enumerate(c)], sample_rate=c.sample_rate)


@pytest.fixture(scope="module")
def projections(speech_corpus):
    return fit_side_projections(speech_corpus.subset([0, 1, 2, 3]), SPEECH_SIDES)


# -- speech sides --------------------------------------------------------------------------------------
def test_sides_are_parsed_and_unknown_ones_named():
    assert parse_sides("all") == SPEECH_SIDES == parse_sides(None) == ("praat", "own", "energy")
    assert parse_sides("energy, praat,energy") == ("energy", "praat")
    for bad in ("pitch", "", "praat,x"):
        with pytest.raises(ParameterError, match="speech sides are praat, own, energy"):
            parse_sides(bad)


def test_each_side_reads_what_it_says(speech_corpus):
    from headmotion.features import extract

    a = speech_corpus[0].audio
    f = sides_features(a, SPEECH_SIDES, fps=FPS)
    praat = extract("f0e", a, fps=FPS)
    np.testing.assert_array_equal(f["praat"].values, praat.values)  # the measure as before
    np.testing.assert_array_equal(speech_features(a).values, praat.values)
    assert tuple(f["own"].names) == F0E_COLUMNS and tuple(f["energy"].names) == ENERGY_COLUMNS
    own = extract("f0e-live", a, fps=FPS, voicing=True, voicing_threshold=0.45)
    np.testing.assert_array_equal(f["own"].values, own.select(F0E_COLUMNS).values)
    np.testing.assert_array_equal(side_features(a, "energy", fps=FPS).values, praat.select(ENERGY_COLUMNS).values)


def test_a_delayed_copy_of_the_energy_is_tied_under_every_side_and_an_unrelated_head_under_none(
        speech_corpus, projections):
    speech = {r.id: r.audio for r in speech_corpus.subset([4, 5])}
    rows = speech_coupling(None, {"tied": _EnergyFollower(), "untied": _EnergyFollower(other=speech_corpus[0].audio)},
                           speech, seeds=[0, 1], n_shifts=60, projections=projections, sides=SPEECH_SIDES)
    got = {(r["side"], r["system"]): r for r in rows if r["file"] == "ALL" and r["seed"] == "ALL"}
    for side in SPEECH_SIDES:
        assert got[(side, "tied")]["excess"] > 0.2 and got[(side, "tied")]["p"] < 0.01, side
        assert got[(side, "untied")]["p"] > 0.05, side
    assert len([r for r in rows if r["file"] != "ALL"]) == 3 * 2 * 2 * 2  # sides × systems × seeds × files
    table = pooled_table(rows)
    for side in SPEECH_SIDES:
        assert f"| {side} | clean | tied |" in table
    assert "ratio to level" not in table  # no level given, no ratio column


def test_the_level_row_is_there_and_the_ratio_is_excess_over_the_level(speech_corpus, projections):
    speech = {r.id: r.audio for r in speech_corpus.subset([4, 5])}
    rows = speech_coupling(None, {"half": _EnergyFollower(gain=0.3), "level": _EnergyFollower()}, speech,
                           seeds=[0, 1], n_shifts=40, projections=projections, sides=("praat", "energy"),
                           levels={"half": "level"})
    pooled = {(r["side"], r["system"], r["seed"]): r for r in rows if r["file"] == "ALL"}
    for side in ("praat", "energy"):
        for seed in (0, 1, "ALL"):
            me, lv = pooled[(side, "half", seed)], pooled[(side, "level", seed)]
            assert me["level"] == "level" and lv["level"] == "" and np.isnan(lv["ratio"])
            assert me["ratio"] == pytest.approx(me["excess"] / lv["excess"])
    table = pooled_table(rows)
    assert "ratio to level" in table
    line = next(ln for ln in table.splitlines() if ln.startswith("| energy | clean | half |"))
    assert f"{pooled[('energy', 'half', 'ALL')]['ratio']:.2f}" in line
    with pytest.raises(ParameterError, match="levels name systems that are not evaluated"):
        speech_coupling(None, {"half": _EnergyFollower()}, speech, seeds=[0], projections=projections,
                        sides=("praat", "energy"), levels={"half": "nowhere"})


def test_ratio_needs_a_level_above_its_null():
    assert L.ratio(0.2, 0.25) == pytest.approx(0.8)
    assert np.isnan(L.ratio(0.2, 0.0)) and np.isnan(L.ratio(0.2, -0.1)) and np.isnan(L.ratio(float("nan"), 0.3))


# -- the Praat-read library -------------------------------------------------------------------------------
def test_the_twin_reads_praat_and_changes_only_what_f0e_refuses():
    from headmotion.synthesis import load_model

    for name in ("default", "stream"):
        params = load_model(name).get_params()
        twin = L.praat_twin_params(params)
        changed = {k for k in params if params[k] != twin[k]}
        assert twin["prosody"] == "f0e" and not twin["live"]
        assert changed <= {"prosody", "live", "lookahead_ms"} and "prosody" in changed
        assert L.has_level("motion-match", params) and not L.has_level("motion-match", twin)
    reading_ahead = {**load_model("stream").get_params(), "lookahead_ms": 200.0}
    assert L.praat_twin_params(reading_ahead)["lookahead_ms"] == 0.0  # a model that is not live refuses it
    with pytest.raises(ParameterError, match="reads? Praat's f0e already"):
        L.praat_twin_params({"prosody": "f0e", "live": False})
    with pytest.raises(ParameterError, match="only for motion-match"):
        L.praat_twin_params({"hidden": 8})
    assert not L.has_level("tws-hier", {"prosody": "f0e-live"})


def test_the_level_of_a_model_is_its_library_read_by_praat(speech_corpus):
    from headmotion.systems.base import create

    model = create("motion-match", prosody="f0e-live", voicing_threshold=0.45, hop=8).fit(speech_corpus)
    level = L.praat_read_level(model, speech_corpus)
    assert level.get_params()["prosody"] == "f0e" and level.get_params()["hop"] == 8
    assert level.lib_motion_.shape == model.lib_motion_.shape  # the same recordings, the same library
    m = level.predict(speech_corpus[0].audio, seed=0)
    assert len(m) > 0
    with pytest.raises(ParameterError, match="only for motion-match"):
        L.praat_read_level(_EnergyFollower(), speech_corpus)


def test_evaluate_speech_puts_the_level_beside_the_model(tmp_path, speech_corpus):
    from typer.testing import CliRunner

    from headmotion.cli import app
    from headmotion.io import save_audio
    from headmotion.systems.base import create

    speech_corpus.subset([0, 1, 2, 3]).save(tmp_path / "corpus")
    create("motion-match", prosody="f0e-live", hop=8).fit(speech_corpus.subset([0, 1, 2, 3])).save(tmp_path / "mm.hmz")
    for r in speech_corpus.subset([4, 5]):
        save_audio(r.audio.slice_seconds(0, 8.0), tmp_path / "speech" / f"{r.id}.wav")
    out = tmp_path / "r"
    res = CliRunner().invoke(app, ["evaluate-speech", str(tmp_path / "corpus"), str(tmp_path / "speech"), "--systems",
                                   str(tmp_path / "mm.hmz"), "--seeds", "0", "--shifts", "20", "--level-exclude", "",
                                   "-o", str(out)])
    assert res.exit_code == 0, res.output
    md = (out / "speech_coupling.md").read_text()
    level = L.level_name(str(tmp_path / "mm.hmz"))
    for side in SPEECH_SIDES:
        assert f"| {side} | clean | {level} |" in md
    assert "ratio to level" in md and "## Files" in md
    csv = (out / "speech_coupling.csv").read_text().splitlines()
    assert csv[0] == "side,degradation,system,seed,file,excess,p,score,level,ratio"


# -- the speech-only set ----------------------------------------------------------------------------------
def test_the_set_states_each_files_kind(tmp_path):
    from headmotion.evaluation.protocol.speech_set import SPEECH_SET, describe, speech_set_files

    assert describe("jfk") == ("phone-like", "English") and describe("chinese_news.wav") == ("language", "Mandarin")
    assert describe("RD_Radio31_000")[0] == "broadcast" and describe("elsewhere") == ("–", "–")
    assert len(SPEECH_SET) == 12 and "speech/video_retalking_1.wav" not in SPEECH_SET  # a corpus recording's speech
    with pytest.raises(FormatError, match="shared data folder"):
        speech_set_files(tmp_path)
    (tmp_path / "speech").mkdir()
    (tmp_path / "speech" / "jfk.flac").write_bytes(b"")
    found, missing = speech_set_files(tmp_path, repository=tmp_path)
    assert [p.name for p in found] == ["jfk.flac"] and len(missing) == 11
    assert any("(optional)" in m for m in missing)
    rows = [{"side": s, "degradation": "clean", "system": "m", "seed": 0, "file": "jfk", "excess": 0.1, "p": 0.5,
             "score": 0.1} for s in SPEECH_SIDES]
    assert "| jfk | phone-like | English | +0.10 / +0.10 / +0.10 |" in files_table(rows, describe)


@pytest.mark.skipif(not (SHARED / "speech").is_dir(), reason="needs ../shared/data/speech (the speech-only set)")
def test_the_documented_set_is_found_in_the_shared_data():
    from headmotion.evaluation.protocol.speech_set import speech_set_files

    found, missing = speech_set_files(SHARED)
    assert len(found) + len(missing) == 12
    assert all("(optional)" in m for m in missing), missing
    assert "video_retalking_1.wav" not in {p.name for p in found}


# -- evaluate: the coupling's sides and the level on held-out sources ---------------------------------------
def test_evaluate_sources_scores_every_side_beside_the_level(tmp_path, speech_corpus):
    import dataclasses

    from headmotion.evaluation.protocol.protocols import evaluate
    from headmotion.evaluation.reporting.levels_report import levels_md
    from headmotion.systems.base import create

    speech_corpus.save(tmp_path / "c")
    c = Corpus.load(tmp_path / "c")
    Corpus(root=tmp_path / "c", entries=[dataclasses.replace(e, source="abc"[i // 2])
                                         for i, e in enumerate(c.entries)]).save(tmp_path / "c")
    c = Corpus.load(tmp_path / "c")
    model = create("motion-match", prosody="f0e-live", hop=8).fit(speech_corpus).save(tmp_path / "mm.hmz")
    res = evaluate(c, ["motion-match[prosody=f0e-live;hop=8]", str(model), "still"], protocol="sources", n_shifts=20,
                   feature_sets=[], samples=1, detectability=False, level=True)
    trained = next(s for s in res.systems if s.startswith("motion-match["))  # the label evaluate gives it
    assert res.config["levels"] == {trained: L.level_name(trained), str(model): L.level_name(str(model))}
    assert res.config["speech_sides"] == list(SPEECH_SIDES)
    assert {L.level_name(trained), L.level_name(str(model))} <= set(res.systems) and "still" in res.systems
    for metric in ("xcca_excess_pooled", "xcca_own_excess_pooled", "xcca_energy_excess_pooled"):
        assert len(res.values(L.level_name(trained), metric)) == 1
        assert len(res.values("ground-truth", metric)) == 1
    md = levels_md(res)
    assert "## Coupling beside its levels" in md and "ratio to recorded heads" in md
    line = next(ln for ln in md.splitlines() if ln.startswith(f"| energy | {trained} |"))
    ex, lv = res.mean(trained, "xcca_energy_excess_pooled"), res.mean(L.level_name(trained), "xcca_energy_excess_pooled")
    assert line.split("|")[5].strip() == (f"{ex / lv:.2f}" if lv > 0 else "–")
    assert "| a | 2 |" in md  # per held-out source
    # praat alone: the measure as before, nothing of the other sides
    only = evaluate(c, ["still"], protocol="sources", n_shifts=20, feature_sets=[], samples=1, detectability=False,
                    speech_sides="praat")
    assert len(only.values("ground-truth", "xcca_excess_pooled")) == 1
    assert len(only.values("ground-truth", "xcca_own_excess_pooled")) == 0 and not only.config["levels"]


# -- the choice scripts' level ---------------------------------------------------------------------------------
def test_level_variants_add_each_twin_or_one_level():
    variants = {"now": {"prosody": "f0e-live", "centred": True}, "stream": {"live": True, "hop": 2},
                "praat": {"prosody": "f0e"}}
    each, of = L.level_variants(variants)
    assert list(each)[:3] == list(variants) and of == {"now": L.level_name("now"), "stream": L.level_name("stream"),
                                                      "praat": "praat"}  # a Praat reader is its own level
    assert each[L.level_name("stream")]["prosody"] == "f0e" and each[L.level_name("stream")]["live"] is False
    assert each[L.level_name("now")]["centred"] is True  # the rest as it was
    one, of = L.level_variants(variants, "now")
    assert set(one) == set(variants) | {L.level_name("now")} and set(of.values()) == {L.level_name("now")}
    assert L.level_variants(variants, None) == (variants, {})
    with pytest.raises(ParameterError, match="not one of the variants"):
        L.level_variants(variants, "later")


def test_source_holdout_choice_prints_every_side_and_the_ratio_to_the_level(tmp_path, speech_corpus, capsys):
    import dataclasses
    import importlib.util

    speech_corpus.save(tmp_path / "c")
    c = Corpus.load(tmp_path / "c")
    Corpus(root=tmp_path / "c", entries=[dataclasses.replace(e, source="ab"[i // 4])
                                         for i, e in enumerate(c.entries)]).save(tmp_path / "c")
    path = Path(__file__).resolve().parents[1] / "scripts" / "source_holdout_choice.py"
    spec = importlib.util.spec_from_file_location("source_holdout_choice", path)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    assert script.main([str(tmp_path / "c"), "--held", "b", "--seeds", "0", "--shifts", "20", "--exclude", "",
                        "--variants", '{"now": {"prosody": "f0e-live", "hop": 8}}', "--level"]) == 0
    out = capsys.readouterr().out
    for side in SPEECH_SIDES:
        assert f"| now | {side} |" in out and f"| {L.level_name('now')} | {side} |" in out
    assert "recorded heads praat" in out and f"| now | {L.level_name('now')} |" in out
