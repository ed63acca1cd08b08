"""``headmotion train / synth / stream / templates`` end to end."""

import json
import subprocess
import sys

import numpy as np
import pytest

from headmotion.cli import main
from headmotion.cli.synth_cmds import default_model_path
from headmotion.io import load_motion
from headmotion.synthetic import planted_corpus

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def corpus_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("planted")
    planted_corpus(minutes=2.0, n_recordings=2, seed=1).save(d)
    return d


@pytest.fixture(scope="module")
def speech(tmp_path_factory, corpus_dir):
    return corpus_dir / "planted_000.wav"


def test_default_model_is_shipped_and_small():
    p = default_model_path()
    assert p.exists() and p.stat().st_size < 1_000_000  # motion-match: the library, 25 frames a second of 7 min


@pytest.mark.parametrize("ext", ["bvh", "csv", "json", "npz"])
def test_synth_default_model_all_formats(speech, tmp_path, ext):
    out = tmp_path / f"head.{ext}"
    assert main(["synth", str(speech), "-o", str(out)]) == 0
    m = load_motion(out)
    assert m.fps == 25.0 and 1475 <= len(m) <= 1525 and np.all(np.isfinite(m.rotvec))
    assert np.degrees(m.rotvec).std() > 0.2  # it moves


def test_train_then_synth_samples_fps_gain(corpus_dir, speech, tmp_path):
    model = tmp_path / "b.hmz"
    assert main(["train", str(corpus_dir), "--system", "tws-basic", "-o", str(model), "--seed", "1"]) == 0
    out = tmp_path / "s.npz"
    assert main(["synth", str(speech), "-m", str(model), "-o", str(out), "--samples", "2", "--fps", "50",
                 "--seed", "3"]) == 0
    a, b = load_motion(tmp_path / "s_1.npz"), load_motion(tmp_path / "s_2.npz")
    assert a.fps == 50 and len(a) == len(b)
    assert not np.allclose(a.rotvec, b.rotvec)
    assert main(["synth", str(speech), "-m", str(model), "-o", str(tmp_path / "g0.npz"), "--gain", "0"]) == 0
    assert np.ptp(load_motion(tmp_path / "g0.npz").rotvec, axis=0).max() < 1e-9
    assert main(["templates", "confusion", str(corpus_dir), "-m", str(model)]) == 0


def test_train_speaker_filter_and_errors(corpus_dir, tmp_path, capsys):
    assert main(["train", str(corpus_dir), "--system", "tws-hier", "-o", str(tmp_path / "x.hmz"),
                 "--speaker", "nobody"]) != 0
    assert "nobody" in capsys.readouterr().err
    assert main(["train", str(corpus_dir), "--system", "still", "-o", str(tmp_path / "x.hmz")]) != 0
    assert main(["synth", str(corpus_dir / "planted_000.wav"), "-o", str(tmp_path / "x.bvh"), "-m",
                 str(corpus_dir / "corpus.csv")]) == 1  # ModelFileError: bad input (documented exit codes)
    assert main(["synth", str(tmp_path / "missing.wav"), "-o", str(tmp_path / "x.bvh")]) != 0


def test_stream_cli_json_lines(tmp_path):
    sr = 16000
    t = np.arange(2 * sr) / sr
    x = (0.3 * np.sin(2 * np.pi * 140 * t) * (np.sin(2 * np.pi * 2 * t) > 0)).astype(np.float32)
    pcm = (x * 32767).astype("<i2").tobytes()
    r = subprocess.run([sys.executable, "-m", "headmotion", "stream"], input=pcm, capture_output=True, timeout=300)
    assert r.returncode == 0, r.stderr.decode()
    lines = [json.loads(s) for s in r.stdout.decode().splitlines()]
    assert len(lines) == 50  # 2 s at the stream model's 25 fps
    assert lines[0]["frame"] == 0 and len(lines[-1]["rotvec"]) == 3 and "pitch_yaw_roll_deg" in lines[5]


def test_templates_encode_error_and_analyse(corpus_dir, tmp_path):
    j = tmp_path / "enc.json"
    assert main(["templates", "encode-error", str(corpus_dir), "--json", str(j)]) == 0
    res = json.loads(j.read_text())
    assert res["cosine"] < res["linear"] < res["rms_amplitude"]
    out = tmp_path / "disc"
    assert main(["templates", "analyse", str(corpus_dir), "-o", str(out), "--initialisers", "10,20",
                 "--sets", "2", "--n-main", "30", "--states", "3"]) == 0
    for f in ("fig5_4_stability.png", "fig5_5_intra_inter.png", "fig5_6_histograms.png", "fig5_12_bic.png",
              "discovery.json"):
        assert (out / f).stat().st_size > 0
    assert main(["templates", "analyse", str(corpus_dir), "-o", str(out), "--states", "7"]) != 0


def test_stream_cli_resamples_other_input_rates(tmp_path):
    """Input at 8 kHz goes through one soxr.ResampleStream: the same number of frames as the
    same speech at the model's 16 kHz, and motion of the same character."""
    out = {}
    for sr in (16000, 8000):
        t = np.arange(2 * sr) / sr
        x = (0.3 * np.sin(2 * np.pi * 140 * t) * (np.sin(2 * np.pi * 2 * t) > 0)).astype(np.float32)
        args = [sys.executable, "-m", "headmotion", "stream", "--sample-rate", str(sr), "--chunk-ms", "7"]
        r = subprocess.run(args, input=(x * 32767).astype("<i2").tobytes(), capture_output=True, timeout=300)
        assert r.returncode == 0, r.stderr.decode()
        out[sr] = np.array([json.loads(s)["rotvec"] for s in r.stdout.decode().splitlines()])
    assert len(out[8000]) == len(out[16000]) == 50  # 2 s at 25 fps
    np.testing.assert_allclose(out[8000].std(axis=0), out[16000].std(axis=0), rtol=0.5)


def test_synth_contract_options(speech, tmp_path, capsys):
    """--stochastic goes through set_params (one vocabulary; refused by a system without it),
    --offset shifts the mean pose in degrees, the train summary is one line."""
    from headmotion.rotations import rotvec_to_pitch_yaw_roll

    base, off = tmp_path / "base.npz", tmp_path / "off.npz"
    assert main(["synth", str(speech), "-o", str(base)]) == 0
    assert main(["synth", str(speech), "-o", str(off), "--offset", "2,0,-1"]) == 0
    d = rotvec_to_pitch_yaw_roll(load_motion(off).rotvec).mean(0) - rotvec_to_pitch_yaw_roll(load_motion(base).rotvec).mean(0)
    np.testing.assert_allclose(np.degrees(d), [2.0, 0.0, -1.0], atol=1e-6)
    # the default (motion-match) has no 'stochastic' parameter: refused; a tws-hier model takes it
    capsys.readouterr()
    assert main(["synth", str(speech), "-o", str(tmp_path / "c.npz"), "--stochastic", "cluster"]) == 2
    assert "stochastic" in capsys.readouterr().err
    from conftest import OLD_TWS_MODEL

    tws = str(OLD_TWS_MODEL)
    assert main(["synth", str(speech), "-m", tws, "-o", str(tmp_path / "c.npz"), "--stochastic", "cluster",
                 "--seed", "4"]) == 0
    assert main(["synth", str(speech), "-m", tws, "-o", str(tmp_path / "x.npz"), "--stochastic", "always"]) == 2
    assert "'stochastic' parameter of tws-hier must be one of" in capsys.readouterr().err
    assert main(["synth", str(speech), "-o", str(tmp_path / "x.npz"), "--gain", "1,2"]) != 0


def test_load_model_reads_the_file_once(monkeypatch):
    import headmotion.systems.base as B

    calls = []
    real = B.load_model_file

    def counting(*a, **kw):
        calls.append(a)
        return real(*a, **kw)

    monkeypatch.setattr(B, "load_model_file", counting)
    m = B.load_model(default_model_path())
    assert len(calls) == 1 and m.name == "motion-match" and m.frame_rate == 25.0 and m.sample_rate == 16000
