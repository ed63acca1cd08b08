"""The library's one synthesis path (:mod:`headmotion.synthesis`) and the shipped models by name:
``synthesize`` gives exactly what ``headmotion synth`` writes, ``open_stream`` what the stream
gives, and ``default`` / ``stream`` resolve wherever a model is taken."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from conftest import OLD_TWS_MODEL
from headmotion.cli import main
from headmotion.errors import ModelFileError, ParameterError
from headmotion.io import load_audio, load_motion
from headmotion.shipped import data_dir
from headmotion.synthesis import Controls, list_models, load_model, open_stream, synthesize

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def models():
    return {"default": load_model("default"), "stream": load_model("stream")}


# -- shipped models by name ------------------------------------------------------------------------
def test_shipped_names_resolve_to_the_package_files(models, tmp_path, capsys):
    assert [m.name for m in list_models()] == ["default", "stream"]
    assert [m.path for m in list_models()] == [data_dir() / "default_model.hmz", data_dir() / "default_stream_model.hmz"]
    assert list_models()[0].summary.startswith("motion-match: the default model")
    assert list_models()[1].summary.startswith("motion-match: the streaming default model")
    assert models["default"].name == models["stream"].name == "motion-match"
    assert models["stream"].causal and models["default"].can_stream and not models["default"].causal
    assert load_model(data_dir() / "default_stream_model.hmz").causal  # a path still works
    assert load_model(models["stream"]) is models["stream"]
    with pytest.raises(ModelFileError, match=r"'nope' is neither a shipped model \(default, stream\)"):
        load_model("nope")
    assert main(["models"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:2] == ["default", "motion-match:"] and out[1].split()[:2] == ["stream", "motion-match:"]
    assert main(["models", "--json"]) == 0
    assert [d["name"] for d in json.loads(capsys.readouterr().out)] == ["default", "stream"]
    assert main(["info", "--model", "nope"]) == 1
    assert "default, stream" in capsys.readouterr().err


def test_import_headmotion_stays_light_and_reexports_synthesis():
    code = ("import sys, headmotion; light = 'torch' not in sys.modules and 'headmotion.systems' not in sys.modules; "
            "from headmotion.synthesis import synthesize; print(light, headmotion.synthesize is synthesize)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.stdout.split() == ["True", "True"], r.stderr


# -- controls parsed once ----------------------------------------------------------------------------
def test_controls_parse_known_answers_and_errors():
    c = Controls.parse(gain="1.2,0.5,1", gain_pyr=(None, None, 0.7), offset_degrees="2", offset_pyr_degrees=(None, 90, None))
    assert c.gain == (1.2, 0.5, 0.7)
    assert c.offset == (math.radians(2), math.pi / 2, math.radians(2))
    assert Controls.parse(offset=0.1).offset == (0.1, 0.1, 0.1) and Controls().gain == (1.0, 1.0, 1.0)
    assert Controls(gain="0.5").gain == (0.5, 0.5, 0.5) and not Controls().moves_pose
    for bad, match in [({"gain": "1,2"}, "one number or three"), ({"gain": "x"}, "comma-separated"),
                       ({"gain": float("nan")}, "finite"), ({"style_strength": 2}, "between 0 and 1"),
                       ({"fps": 0}, "between 1 and 1000"), ({"fps": 1500}, "between 1 and 1000"),
                       ({"offset": 1, "offset_degrees": 1}, "not both"),
                       ({"style_from": 3}, "file path or a Motion")]:
        with pytest.raises(ParameterError, match=match):
            Controls.parse(**bad)


def test_synth_parses_the_gain_string_once(examples_dir, tmp_path, monkeypatch):
    import headmotion.synthesis as S

    seen = []
    real = S._triple
    monkeypatch.setattr(S, "_triple", lambda v, *a, **k: (seen.append(v), real(v, *a, **k))[1])
    wav = examples_dir / "speech" / "short.wav"
    assert main(["synth", str(wav), "-m", "stream", "-o", str(tmp_path / "a.npz"), "--gain", "1.3,1,1"]) == 0
    assert seen.count("1.3,1,1") == 1


# -- synthesize == headmotion synth -------------------------------------------------------------------
OPTION_SETS = {
    "plain": ([], {}),
    "seed_samples": (["--seed", "3", "--samples", "2"], {"seed": 3, "samples": 2}),
    "gain_offset": (["--gain", "1.3", "--offset-yaw", "5"], {"gain": 1.3, "offset_pyr_degrees": (None, 5, None)}),
    "still": (["--still", "--offset", "2"], {"still": True, "offset_degrees": 2}),
    "style_gain": (["--style-from", "STYLE", "--gain", "0.8", "--style-strength", "0.6"],
                   {"style_from": "STYLE", "gain": 0.8, "style_strength": 0.6}),
    "fps": (["--fps", "30", "--gain", "1.1,1,0.9"], {"fps": 30, "gain": "1.1,1,0.9"}),
}


def _cli_motions(args, out, samples):
    assert main(args + ["-o", str(out)]) == 0
    if samples == 1:
        return [load_motion(out)]
    return [load_motion(out.with_name(f"{out.stem}_{k + 1}{out.suffix}")) for k in range(samples)]


@pytest.mark.parametrize("name", ["default", "stream"])
@pytest.mark.parametrize("opts", list(OPTION_SETS), ids=list(OPTION_SETS))
def test_synthesize_gives_what_synth_writes(examples_dir, tmp_path, models, name, opts):
    wav = examples_dir / "speech" / "speech_male.wav"
    style = str(examples_dir / "motion" / "nod_shake_tilt.bvh")
    args, kw = OPTION_SETS[opts]
    args = [style if a == "STYLE" else a for a in args]
    kw = {k: (style if v == "STYLE" else v) for k, v in kw.items()}
    seed, samples = kw.pop("seed", 0), kw.pop("samples", 1)
    cli = _cli_motions(["synth", str(wav), "-m", name] + args, tmp_path / "out.npz", samples)
    lib = synthesize(wav, models[name], seed=seed, samples=samples, **kw)
    assert len(lib) == len(cli) == samples
    for a, b in zip(lib, cli):
        assert a.fps == b.fps and len(a) == len(b) > 50
        np.testing.assert_array_equal(a.rotvec, b.rotvec)
    if samples == 2:
        assert not np.allclose(lib[0].rotvec, lib[1].rotvec)  # seed 3 and seed 4 differ
    if opts == "still":
        np.testing.assert_allclose(np.ptp(lib[0].rotvec, axis=0), 0.0, atol=1e-12)
    if opts == "fps":
        assert lib[0].fps == 30.0


def test_synthesize_audio_object_and_progress(examples_dir, models):
    wav = examples_dir / "speech" / "short.wav"
    calls = []
    a = synthesize(load_audio(wav), models["stream"], seed=1, samples=2, progress=lambda d, t: calls.append((d, t)))
    b = synthesize(wav, "stream", seed=1, samples=2)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x.rotvec, y.rotvec)
    assert len(calls) == 2 and calls[-1][0] == pytest.approx(calls[-1][1])
    tws = load_model(OLD_TWS_MODEL)  # a system with a 'stochastic' parameter
    choice = synthesize(wav, tws, seed=1, stochastic="choice")[0]
    assert tws.get_params()["stochastic"] == "params"  # the caller's model is left as it was
    assert not np.array_equal(choice.rotvec, synthesize(wav, tws, seed=1)[0].rotvec)
    with pytest.raises(ParameterError, match="motion-match has no parameter 'stochastic'"):
        synthesize(wav, "stream", stochastic="choice")
    with pytest.raises(ParameterError, match="not both"):
        synthesize(wav, "stream", controls=Controls(), gain=2)
    with pytest.raises(ParameterError, match="samples"):
        synthesize(wav, "stream", samples=0)


def test_long_input_is_read_in_blocks_by_both(examples_dir, tmp_path, models, monkeypatch):
    import headmotion.systems.long_input as LI
    from headmotion.synthesis import reads_in_blocks

    wav = examples_dir / "speech" / "speech_male.wav"
    whole = synthesize(wav, models["default"], seed=2, gain=1.2)[0]
    monkeypatch.setattr(LI, "LONG_INPUT_SECONDS", 1.0)
    assert reads_in_blocks(models["default"], wav) and not reads_in_blocks(models["default"], load_audio(wav))
    blocks = synthesize(wav, models["default"], seed=2, gain=1.2)[0]
    cli = _cli_motions(["synth", str(wav), "--seed", "2", "--gain", "1.2"], tmp_path / "b.npz", 1)[0]
    np.testing.assert_array_equal(blocks.rotvec, cli.rotvec)
    np.testing.assert_array_equal(blocks.rotvec, whole.rotvec)  # the stream makes predict's decisions


# -- open_stream -----------------------------------------------------------------------------------------
def test_open_stream_gives_the_causal_models_offline_motion(examples_dir, models):
    wav = examples_dir / "speech" / "speech_male.wav"
    kw = {"gain": 1.4, "offset_degrees": "1,-2,0"}
    offline = synthesize(wav, models["stream"], seed=5, **kw)[0]
    st = open_stream(models["stream"], seed=5, **kw)
    assert st.sample_rate == models["stream"].sample_rate and st.frame_rate == 25.0
    x = load_audio(wav, sample_rate=st.sample_rate).samples
    parts = [st.push(x[i:i + 1601]).rotvec for i in range(0, len(x), 1601)] + [st.flush().rotvec]
    rv = np.vstack([p for p in parts if len(p)])
    assert len(rv) == len(offline)
    np.testing.assert_allclose(rv, offline.rotvec, atol=1e-9)


def test_open_stream_resamples_and_refuses_whole_recording_controls(examples_dir):
    wav = examples_dir / "speech" / "short.wav"
    x = load_audio(wav, sample_rate=8000).samples
    st = open_stream("stream", sample_rate=8000, still=True, offset_degrees="0,10,0")
    rv = np.vstack([st.push(x[i:i + 800]).rotvec.reshape(-1, 3) for i in range(0, len(x), 800)]
                   + [st.flush().rotvec.reshape(-1, 3)])
    assert abs(len(rv) - round(len(x) / 8000 * 25)) <= 1
    from headmotion.rotations import rotvec_to_pitch_yaw_roll

    np.testing.assert_allclose(np.degrees(rotvec_to_pitch_yaw_roll(rv)), np.tile([0, 10, 0], (len(rv), 1)), atol=1e-9)
    with pytest.raises(ParameterError, match="whole recording"):
        open_stream("stream", style_from=str(wav))
    with pytest.raises(ParameterError, match="whole recording"):
        open_stream("stream", fps=30)


# -- real speech -----------------------------------------------------------------------------------------
def test_real_speech_styled_by_mocap_matches_the_command(shared_data, tmp_path, models):
    wav = shared_data / "speech" / "jfk.flac"
    bvhs = sorted((shared_data / "mocap_speech" / "zeggs").glob("*.bvh"))
    if not wav.is_file() or not bvhs:
        pytest.skip("jfk.flac or the ZEGGS take is absent from the shared data")
    args = ["synth", str(wav), "-m", "default", "--style-from", str(bvhs[0]), "--gain", "1.3", "--offset-pitch", "-3",
            "--seed", "1", "--samples", "2", "--fps", "30"]
    cli = _cli_motions(args, tmp_path / "z.npz", 2)
    lib = synthesize(wav, "default", seed=1, samples=2, style_from=bvhs[0], gain=1.3,
                     offset_pyr_degrees=(-3, None, None), fps=30)
    for a, b in zip(lib, cli):
        np.testing.assert_array_equal(a.rotvec, b.rotvec)
    assert lib[0].fps == 30 and abs(lib[0].duration - 11.0) < 0.1


def test_the_order_of_the_controls_from_the_parts(examples_dir, models):
    """model motion → style → gain about the styled mean pose (the model's when it is kept) →
    offset → fps, spelled out with the parts each control is made of."""
    from headmotion.motion.control import apply_gain, mean_pose_of
    from headmotion.motion.style import apply_style, style_profile
    from headmotion.video.reference import load_style_reference

    m = models["default"]
    wav = examples_dir / "speech" / "speech_male.wav"
    ref_file = examples_dir / "motion" / "nod_shake_tilt.bvh"
    ref = style_profile(load_style_reference(ref_file))
    raw = m.predict(load_audio(wav), seed=4)
    g, o = (1.3, 0.7, 1.0), (0.0, math.radians(5), 0.0)
    for keep in (False, True):
        styled = apply_style(raw, ref, strength=0.5, match_mean=not keep)
        mean = m.mean_pose_ if keep else mean_pose_of([styled.rotvec])
        want = apply_gain(styled, mean, g, o).resample(50)
        got = synthesize(wav, m, seed=4, style_from=ref_file, style_strength=0.5, style_keep_pose=keep,
                         gain=g, offset=o, fps=50)[0]
        np.testing.assert_array_equal(got.rotvec, want.rotvec)
    plain = synthesize(wav, m, seed=4, gain=g, offset=o)[0]
    np.testing.assert_array_equal(plain.rotvec, apply_gain(raw, m.mean_pose_, g, o).rotvec)


def test_a_system_name_given_as_a_model_says_how_to_train_one():
    from headmotion.errors import ModelFileError
    from headmotion.shipped import resolve_model_path

    with pytest.raises(ModelFileError, match=r"'tws-hier' is a system, not a model: train one"):
        resolve_model_path("tws-hier")
