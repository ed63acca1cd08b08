"""Public dataset layouts imported as corpora (BEAT2, AMASS-style SMPL-X), and the trimming rule
every corpus command shares: speech and motion within 1 s and 2 % are cut to the shorter track,
beyond that refused at import naming both lengths.  The folders are built here with files of the
real shapes (SMPL-X ``poses`` of width 165, ``mocap_frame_rate`` 30, 16 kHz speech)."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf
from typer.testing import CliRunner

from headmotion.align import recording_tolerance_s
from headmotion.cli import app, main
from headmotion.corpus import Corpus, check_corpus
from headmotion.datasets import check_pair, import_dataset
from headmotion.errors import LengthMismatchError, ParameterError

runner = CliRunner()


def _smplx(path, seconds, fps=30, seed=0, nod_deg=8.0):
    """An SMPL-X take as BEAT2 ships it; the neck (joint 12) nods about x with a known amplitude."""
    n = int(round(seconds * fps))
    poses = np.zeros((n, 165), np.float64)
    t = np.arange(n) / fps
    poses[:, 12 * 3] = np.radians(nod_deg) * np.sin(2 * np.pi * 0.7 * t + seed)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, poses=poses, trans=np.zeros((n, 3)), betas=np.zeros(300), expressions=np.zeros((n, 100)),
             mocap_frame_rate=np.array(fps), model=np.array("smplx2020"), gender=np.array("neutral"))


def _speech(path, seconds, sr=16000, seed=0):
    rng = np.random.default_rng(seed)
    n = int(round(seconds * sr))
    t = np.arange(n) / sr
    voiced = (np.sin(2 * np.pi * 1.5 * t) > -0.3).astype(np.float32)  # syllable-like bursts and gaps
    x = voiced * (0.3 * np.sin(2 * np.pi * 140 * t) + 0.02 * rng.standard_normal(n))
    path.parent.mkdir(parents=True, exist_ok=True)
    sf.write(path, x.astype(np.float32), sr)


def _beat2(root, takes):
    """takes: (id, speech seconds, motion seconds, split type)."""
    rows = ["id,type"]
    for k, (rid, a, m, kind) in enumerate(takes):
        _smplx(root / "smplxflame_30" / f"{rid}.npz", m, seed=k)
        _speech(root / "wave16k" / f"{rid}.wav", a, seed=k)
        rows.append(f"{rid},{kind}")
    (root / "train_test_split.csv").write_text("\n".join(rows) + "\n")
    return root


def test_tolerance_rule_known_values():
    assert recording_tolerance_s((64.10, 63.53)) == pytest.approx(1.0)  # 2 % of 63.53 s is 1.27 s: capped at 1 s
    assert recording_tolerance_s((10.0, 10.3)) == pytest.approx(0.2)   # 2 % of 10 s
    assert recording_tolerance_s((2.0, 2.5)) == pytest.approx(0.05)    # short clips keep the 50 ms floor


def test_beat2_pair_trimmed_and_reported(tmp_path):
    """The pair from the field (64.10 s of speech, 63.53 s of motion) is accepted, trimmed to the
    motion, and the cut is reported by the import and by corpus check."""
    root = _beat2(tmp_path / "beat2", [("2_scott_0_1_1", 64.10, 63.53, "train")])
    c = check_pair(root / "wave16k/2_scott_0_1_1.wav", root / "smplxflame_30/2_scott_0_1_1.npz")
    assert c.trimmed_s == pytest.approx(0.57, abs=0.02) and c.longer == "speech"
    out = tmp_path / "corpus"
    res = runner.invoke(app, ["corpus", "import-dataset", "beat2", str(root), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "trimmed by 0.5" in res.output and "speech 64.100 s, motion 63.533 s" in res.output
    rec = Corpus.load(out)[0]
    assert rec.speaker == "scott" and rec.split == "train"
    assert rec.duration == pytest.approx(63.53, abs=0.04)
    assert rec.meta["trimmed"]["audio_s"] == pytest.approx(0.57, abs=0.04)
    rows, problems = check_corpus(Corpus.load(out))
    assert rows[0]["trimmed_s"] == pytest.approx(0.57, abs=0.04) and not any("differ" in p for p in problems)
    res = runner.invoke(app, ["corpus", "check", str(out)])
    assert "nan" not in res.output and "trimmed" in res.output


def test_beat2_split_speakers_and_refusal(tmp_path):
    root = _beat2(tmp_path / "beat2", [
        ("2_scott_0_1_1", 12.1, 12.0, "train"), ("2_scott_0_2_2", 12.0, 12.0, "val"),
        ("4_lawrence_0_3_3", 12.0, 12.05, "test"), ("4_lawrence_0_4_4", 12.0, 12.0, "additional"),
        ("6_carla_0_5_5", 14.0, 12.0, "train")])  # 2 s apart: beyond the rule
    summary = import_dataset("beat2", root, tmp_path / "c")
    got = {it.recording: (it.speaker, it.split) for it, _ in summary.accepted}
    assert got == {"2_scott_0_1_1": ("scott", "train"), "2_scott_0_2_2": ("scott", "valid"),
                   "4_lawrence_0_3_3": ("lawrence", "test")}  # additional left out by default
    assert len(summary.refused) == 1 and "6_carla_0_5_5" in summary.refused[0][1]
    assert "14.000 s" in summary.refused[0][1] and "12.000 s" in summary.refused[0][1]
    corpus = Corpus.load(tmp_path / "c")
    assert sorted(e.split for e in corpus.entries) == ["test", "train", "valid"]
    with pytest.raises(ParameterError, match="nothing written"):
        import_dataset("beat2", root, tmp_path / "strict", strict=True)
    assert not (tmp_path / "strict").exists()
    with_extra = import_dataset("beat2", root, tmp_path / "c2", additional=True)
    assert {it.recording for it, _ in with_extra.accepted} >= {"4_lawrence_0_4_4"}


def test_amass_layout_speakers_from_folders(tmp_path):
    root = tmp_path / "amass"
    for subj, take, a, m in [("S1", "talk_01", 8.05, 8.0), ("S2", "talk_01", 9.0, 9.0)]:
        _smplx(root / "SET" / subj / f"{take}.npz", m)
        _speech(tmp_path / "audio" / "SET" / subj / f"{take}.wav", a)  # same relative path: each its own
    _smplx(root / "SET" / "S3" / "lonely.npz", 5.0)  # no speech anywhere: reported, skipped
    summary = import_dataset("amass", root, tmp_path / "c", audio_dir=tmp_path / "audio")
    got = {it.recording: it.speaker for it, _ in summary.accepted}
    assert got == {"SET_S1_talk_01": "S1", "SET_S2_talk_01": "S2"}
    assert any("lonely" in p for p in summary.problems)
    with pytest.raises(ParameterError, match="amass layout"):
        import_dataset("beat2", root, tmp_path / "x", audio_dir=tmp_path / "audio")


def test_corpus_import_refuses_at_import_what_training_would(tmp_path, capsys):
    """`corpus import` of a pair beyond the rule fails at once, names both lengths, writes nothing."""
    _smplx(tmp_path / "take.npz", 10.0)
    _speech(tmp_path / "take.wav", 11.0)
    code = main(["corpus", "import", str(tmp_path / "take.wav"), str(tmp_path / "take.npz"),
                 "-o", str(tmp_path / "c"), "--speaker", "a"])
    err = capsys.readouterr().err
    assert code != 0 and "Traceback" not in err
    assert "11.000 s" in err and "10.000 s" in err
    assert not (tmp_path / "c" / "corpus.csv").exists()
    with pytest.raises(LengthMismatchError):
        check_pair(tmp_path / "take.wav", tmp_path / "take.npz")


def test_check_describes_a_recording_that_does_not_load(tmp_path):
    """A pair made bad after import is still described (motion length and rate), never NaN."""
    _smplx(tmp_path / "take.npz", 10.0)
    _speech(tmp_path / "take.wav", 10.0)
    out = tmp_path / "c"
    assert runner.invoke(app, ["corpus", "import", str(tmp_path / "take.wav"), str(tmp_path / "take.npz"),
                               "-o", str(out), "--speaker", "a"]).exit_code == 0
    _speech(tmp_path / "take.wav", 20.0)
    rows, problems = check_corpus(Corpus.load(out))
    assert rows[0]["minutes"] == pytest.approx(10.0 / 60, abs=1e-3) and rows[0]["fps"] == 30
    assert problems and "differ" in problems[0]
    res = runner.invoke(app, ["corpus", "check", str(out)])
    assert res.exit_code == 1 and "nan" not in res.output


def test_feature_cache_resumes_and_recomputes_stale(tmp_path):
    """The corpus feature cache: every recording once; a second run computes nothing; the files
    equal the features computed directly; a changed speech file is recomputed."""
    from headmotion.features import FeatureConfig
    from headmotion.feature_cache import build_feature_cache, cache_path, load_cached

    root = _beat2(tmp_path / "beat2", [("2_scott_0_1_1", 3.0, 3.0, "train"), ("4_ann_0_1_1", 2.5, 2.5, "test")])
    import_dataset("beat2", root, tmp_path / "c")
    corpus = Corpus.load(tmp_path / "c")
    config = FeatureConfig("f0e", fps=100.0)
    assert build_feature_cache(corpus, config) == {"computed": 2, "cached": 0}
    assert build_feature_cache(corpus, config) == {"computed": 0, "cached": 2}
    direct = config.extract(corpus["4_ann_0_1_1"].audio)
    got = load_cached(corpus, "4_ann_0_1_1", config)
    np.testing.assert_array_equal(got.values, direct.values)
    assert cache_path(corpus.root, "4_ann_0_1_1", config).parent.name.startswith("f0e-")
    _speech(root / "wave16k" / "4_ann_0_1_1.wav", 2.5, seed=9)  # edited: the cached file is stale
    assert load_cached(Corpus.load(tmp_path / "c"), "4_ann_0_1_1", config) is None
    assert build_feature_cache(Corpus.load(tmp_path / "c"), config) == {"computed": 1, "cached": 1}
