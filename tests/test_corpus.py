"""Corpus manifest, splits by recording (thesis §5.9, paper §4.1), model files without pickle."""

import json
import zipfile

import numpy as np
import pytest

from headmotion import Audio, Motion
from headmotion.corpus import Corpus, Recording, leave_one_out, paper_split
from headmotion.errors import FormatError, LengthMismatchError, ModelFileError, ParameterError
from headmotion.models.serialization import load_model_file, save_model_file


def _rec(i, speaker="s1", seconds=2.0, fps=25.0):
    n = int(seconds * fps)
    t = np.arange(n) / fps
    rv = np.stack([0.05 * np.sin(2 * np.pi * 0.5 * t + i), np.zeros(n), np.zeros(n)], 1)
    audio = Audio(0.1 * np.sin(2 * np.pi * 200 * np.arange(int(seconds * 16000)) / 16000), 16000)
    return Recording.aligned(f"r{i}", speaker, "read", audio, Motion(rv, fps))


def test_recording_aligned_rejects_mismatch():
    audio = Audio(np.zeros(16000 * 3), 16000)
    with pytest.raises(LengthMismatchError, match="r0 audio"):
        Recording.aligned("r0", "s", "t", audio, Motion(np.zeros((50, 3)), 25))


def test_speaking_mask_shape_checked():
    r = _rec(0)
    with pytest.raises(ParameterError, match="speaking mask"):
        Recording("x", "s", "t", r.audio, r.motion, speaking=np.ones(3, bool))


def test_leave_one_out_is_per_speaker():
    c = Corpus([_rec(0), _rec(1), _rec(2), _rec(3, "s2"), _rec(4, "s2"), _rec(5, "s3")])
    folds = list(leave_one_out(c))
    assert [f[0] for f in folds] == ["r0", "r1", "r2", "r3", "r4"]  # s3 has one recording: no fold
    held, train, test = folds[0]
    assert test.ids == ["r0"] and sorted(train.ids) == ["r1", "r2"]


@pytest.mark.parametrize("n,expected", [(1, (1, 0, 0)), (2, (1, 0, 1)), (3, (1, 1, 1)), (10, (6, 2, 2)), (5, (3, 1, 1))])
def test_paper_split_proportions(n, expected):
    c = Corpus([_rec(i) for i in range(n)])
    s = paper_split(c, seed=3)
    counts = tuple(sum(v == k for v in s.values()) for k in ("train", "valid", "test"))
    assert counts == expected
    assert s == paper_split(c, seed=3)  # reproducible


def test_manifest_errors_name_file_and_line(tmp_path):
    (tmp_path / "corpus.csv").write_text("recording,speaker,task,audio\nr1,s,t,a.wav\n")
    with pytest.raises(FormatError, match=r"corpus.csv, line 1: missing column"):
        Corpus.load(tmp_path)
    (tmp_path / "corpus.csv").write_text("recording,speaker,task,audio,motion\nr1,s,t,a.wav,\n")
    with pytest.raises(FormatError, match="line 2: empty value in column 'motion'"):
        Corpus.load(tmp_path)
    with pytest.raises(FormatError, match="not a corpus directory"):
        Corpus.load(tmp_path / "nowhere")
    (tmp_path / "corpus.csv").unlink()
    with pytest.raises(FormatError, match="no corpus.csv"):
        Corpus.load(tmp_path)


def test_corpus_save_and_load_round_trip(tmp_path):
    c = Corpus([_rec(0), _rec(1, "s2")])
    c.save(tmp_path)
    back = Corpus.load(tmp_path)
    assert back.ids == ["r0", "r1"] and back.speakers == ["s1", "s2"]
    np.testing.assert_allclose(back["r0"].motion.rotvec, c["r0"].motion.rotvec, atol=1e-9)
    assert back.summary()["minutes"] == pytest.approx(4 / 60, abs=1e-3)


def test_model_file_round_trip_and_damage(tmp_path):
    p = tmp_path / "m.hmz"
    save_model_file(p, system="tws-hier", config={"k": 4}, arrays={"means": np.arange(6.0).reshape(2, 3)})
    config, arrays = load_model_file(p, expect_system="tws-hier")
    assert config["k"] == 4 and config["system"] == "tws-hier"
    np.testing.assert_array_equal(arrays["means"], np.arange(6.0).reshape(2, 3))
    with pytest.raises(ModelFileError, match="not a 'cccae' model"):
        load_model_file(p, expect_system="cccae")
    truncated = tmp_path / "t.hmz"
    truncated.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 2])
    with pytest.raises(ModelFileError, match="damaged or truncated"):
        load_model_file(truncated)
    foreign = tmp_path / "f.hmz"
    with zipfile.ZipFile(foreign, "w") as zf:
        zf.writestr("config.json", json.dumps({"hello": 1}))
        zf.writestr("arrays.npz", b"")
    with pytest.raises(ModelFileError):
        load_model_file(foreign)
    with pytest.raises(ModelFileError, match="not found"):
        load_model_file(tmp_path / "missing.hmz")


def test_model_file_refuses_object_arrays(tmp_path):
    with pytest.raises(ModelFileError, match="dtype object"):
        save_model_file(tmp_path / "x.hmz", system="s", config={}, arrays={"a": np.array([{}], dtype=object)})
    assert not (tmp_path / "x.hmz").exists()
    assert not list(tmp_path.iterdir())  # no temp file left behind
