"""The CLI as a user runs it: exit codes, one line on stderr, never a traceback.

Every case runs a real process: ``python -m headmotion`` (``headmotion/__main__.py`` calls
``headmotion.cli.run``, the console script's entry point, which ``test_console_script_entry_point``
checks) with this checkout's ``src`` first on the path, and — where the ``headmotion`` console
script is installed (CI installs the clone editable) — the script itself for a usage error and a
bad file.  ``CliRunner`` is not used: it never meets the code path a fresh install takes
(typer ≥ 0.2x raises ``typer._click`` exceptions, which the old handler missed).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"


def _env(**extra):
    env = dict(os.environ)
    env["PYTHONPATH"] = str(SRC) + os.pathsep + env.get("PYTHONPATH", "")
    env.update({"COLUMNS": "100", "NO_COLOR": "1", "HEADMOTION_DEBUG": ""}, **extra)
    return env


def run_cli(*args, cwd=None, timeout=120, script: str | None = None, **env):
    cmd = [script] if script else [sys.executable, "-m", "headmotion"]
    return subprocess.run(cmd + [str(a) for a in args], capture_output=True, text=True, cwd=cwd,
                          timeout=timeout, env=_env(**env))


def assert_one_line_error(r, code: int, *needles):
    assert r.returncode == code, (r.returncode, r.stdout, r.stderr)
    assert "Traceback" not in r.stderr + r.stdout
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("error: "), lines
    for n in needles:
        assert n in lines[0], (n, lines[0])


# ------------------------------------------------------------------------------ small files
def _motion(T=30, fps=30.0):
    from headmotion.types import Motion

    t = np.arange(T) / fps
    return Motion(np.stack([0.1 * np.sin(t), 0.2 * np.cos(t), 0.05 * t], 1), fps)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Small real-style files, each damaged the way files get damaged."""
    from headmotion.io.audio import save_audio
    from headmotion.io.bvh import save_bvh
    from headmotion.io.native import save_json
    from headmotion.models.serialization import save_model_file
    from headmotion.types import Audio

    d = tmp_path_factory.mktemp("bad")
    good = d / "good.bvh"
    save_bvh(_motion(), good)
    text = good.read_text()
    out = {"good_bvh": good}
    edits = {
        "frames_1e9": ("Frames: 30", "Frames: 1000000000"),
        "frames_neg": ("Frames: 30", "Frames: -3"),
        "channels_300": ("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 300 Zrotation Xrotation Yrotation"),
        "frame_time_0": ("Frame Time: 0.0333333333333", "Frame Time: 0"),
        "frame_time_tiny": ("Frame Time: 0.0333333333333", "Frame Time: 1e-320"),
        "frame_time_inf": ("Frame Time: 0.0333333333333", "Frame Time: inf"),
        "hierarchy_typo": ("HIERARCHY", "HIERACHY"),
    }
    for name, (a, b) in edits.items():
        assert a in text, (name, a)
        p = d / f"{name}.bvh"
        p.write_text(text.replace(a, b, 1))
        out[name] = p
    save_audio(Audio(0.1 * np.sin(np.arange(16000) / 5).astype(np.float32), 16000), d / "ok.wav")
    raw = (d / "ok.wav").read_bytes()
    (d / "truncated.wav").write_bytes(raw[: len(raw) // 2])
    out["truncated_wav"] = d / "truncated.wav"
    bad_rate = bytearray(raw)
    bad_rate[24:28] = (0).to_bytes(4, "little")
    (d / "rate0.wav").write_bytes(bytes(bad_rate))
    out["rate0_wav"] = d / "rate0.wav"
    save_json(_motion(), d / "ok.json")
    j = (d / "ok.json").read_text()
    (d / "deep.json").write_text(j.replace('"meta":', '"x":' + "[" * 50000 + "]" * 50000 + ',"meta":'))
    out["deep_json"] = d / "deep.json"
    (d / "bigint.json").write_text(j.replace('"fps":30.0', '"fps":' + "9" * 5000))
    out["bigint_json"] = d / "bigint.json"
    (d / "hugefield.csv").write_text("# headmotion-motion 1 {\"fps\":30}\nframe,time,rx,ry,rz\n0,0,"
                                     + "1" * 200_000 + ",0,0\n")
    out["hugefield_csv"] = d / "hugefield.csv"
    (d / "optitrack_rate0.csv").write_text(
        "Format Version,1.23,Capture Frame Rate,0,Export Frame Rate,0,Rotation Type,Quaternion\n\n"
        ",Type,Rigid Body,Rigid Body,Rigid Body,Rigid Body\n,Name,Head,Head,Head,Head\n"
        ",,Rotation,Rotation,Rotation,Rotation\nFrame,Time (Seconds),X,Y,Z,W\n"
        "0,0,0,0,0,1\n1,0,0,0,0,1\n")
    out["optitrack_rate0"] = d / "optitrack_rate0.csv"
    save_model_file(d / "m.hmz", system="tws-hier", config={"params": {}}, arrays={"a": np.zeros(3)})
    raw = (d / "m.hmz").read_bytes()
    (d / "trunc.hmz").write_bytes(raw[: len(raw) // 2])
    out["trunc_hmz"] = d / "trunc.hmz"
    (d / "notes.txt").write_text("hello")
    out["unknown_ext"] = d / "notes.txt"
    return out


# ------------------------------------------------------------------------------------ usage
USAGE = [
    ("synth", ["synth"], "Missing argument"),
    ("synth unknown option", ["synth", "speech.wav", "--bogus"], "No such option"),
    ("synth --seed abc", ["synth", "speech.wav", "--seed", "abc"], "--seed"),
    ("synth --seed -3", ["synth", "speech.wav", "--seed", "-3"], "--seed"),   # was an internal error
    ("stream --seed -1", ["stream", "--seed", "-1"], "--seed"),
    ("unknown command", ["nope"], "No such command"),
    ("info without a file", ["info"], "Missing argument"),
    ("convert without output", ["convert", "a.bvh"], "Missing argument"),
    ("train without arguments", ["train"], "Missing"),
    ("listen serve without config", ["listen", "serve"], "Missing argument"),
    ("features unknown option", ["features", "--nonsense"], "No such option"),
    ("unknown sub-command", ["corpus", "frobnicate"], "No such command"),
]


@pytest.mark.parametrize("label,args,needle", USAGE, ids=[u[0] for u in USAGE])
def test_usage_errors_exit_2_with_clicks_usage(label, args, needle, tmp_path):
    r = run_cli(*args, cwd=tmp_path)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr + r.stdout
    assert "Usage: headmotion" in r.stderr
    assert needle in r.stderr
    assert r.stdout == ""


@pytest.mark.parametrize("args,word", [([], "synth"), (["corpus"], "check"), (["templates"], "encode-error"),
                                       (["listen"], "serve"), (["--help"], "Exit codes")])
def test_group_alone_shows_help(args, word):
    r = run_cli(*args)
    assert r.returncode == 0, r.stderr
    assert "Usage:" in r.stdout and word in r.stdout
    assert "Traceback" not in r.stderr


# -------------------------------------------------------------------------------- bad files
BAD = [("frames_1e9", "info", "Frames"), ("frames_neg", "info", "Frames"),
       ("channels_300", "info", "CHANNELS"), ("frame_time_0", "info", "Frame Time"),
       ("frame_time_tiny", "info", "Frame Time"), ("frame_time_inf", "info", "Frame Time"),
       ("hierarchy_typo", "info", "HIERARCHY"), ("truncated_wav", "info", "truncated"),
       ("rate0_wav", "info", "sample rate"), ("deep_json", "info", "nested"),
       ("bigint_json", "info", "digits"), ("hugefield_csv", "info", "field"),
       ("optitrack_rate0", "info", "Frame Rate"), ("trunc_hmz", "info", "model"),
       ("unknown_ext", "info", "extension"),
       ("frames_1e9", "convert", "Frames"), ("channels_300", "convert", "CHANNELS"),
       ("frame_time_0", "convert", "Frame Time"), ("hierarchy_typo", "convert", "HIERARCHY")]


@pytest.mark.parametrize("name,cmd,needle", BAD, ids=[f"{c}-{n}" for n, c, _ in BAD])
def test_bad_file_is_one_line_exit_1(files, name, cmd, needle, tmp_path):
    p = files[name]
    args = [cmd, p] + ([tmp_path / "out.csv"] if cmd == "convert" else [])
    r = run_cli(*args)
    assert_one_line_error(r, 1, p.name, needle)
    if cmd == "convert":
        assert list(tmp_path.iterdir()) == []  # nothing written, no partial file


def test_missing_file(tmp_path):
    r = run_cli("info", tmp_path / "nope.bvh")
    assert_one_line_error(r, 1, "nope.bvh", "not found")


def test_bad_value_for_a_reader_option_is_usage(files, tmp_path):
    r = run_cli("convert", files["good_bvh"], tmp_path / "o.csv", "--option", "relative_to=Nose")
    assert_one_line_error(r, 2, "relative_to")


# ------------------------------------------------------------------- 3 / 4 / --debug / markup
_INJECT = """
import sys
from headmotion.cli import app, run
from headmotion.errors import MissingDependencyError

@app.command("boom")
def boom(kind: str):
    if kind == "dep":
        raise MissingDependencyError("corpus from-video needs mediapipe: pip install headmotion[video]")
    if kind == "module":
        import importlib
        sys.modules["mediapipe"] = None
        importlib.import_module("mediapipe")
    if kind == "bug":
        {}["no such key"]
    if kind == "markup":
        from headmotion.errors import FormatError
        raise FormatError("expected [1, 2] or [bold]x[/bold]", path="take[red].bvh")
    if kind == "warn":
        import warnings
        warnings.warn("tws-hier: too little training data for 4 clusters", UserWarning)
        warnings.warn("did not converge", RuntimeWarning)
        print("done")

run()
"""


def _inject(*args, **env):
    return subprocess.run([sys.executable, "-c", _INJECT, *args], capture_output=True, text=True,
                          timeout=120, env=_env(**env))


def test_missing_optional_dependency_exit_3_keeps_brackets():
    r = _inject("boom", "dep")
    assert_one_line_error(r, 3, "pip install headmotion[video]")
    r = _inject("boom", "module")
    assert_one_line_error(r, 3, "mediapipe", "headmotion[video]")


def test_internal_error_exit_4_with_debug_hint():
    r = _inject("boom", "bug")
    assert_one_line_error(r, 4, "internal error", "KeyError", "--debug")
    d = _inject("boom", "bug", "--debug")
    assert d.returncode == 4
    assert "Traceback" in d.stderr and "KeyError" in d.stderr
    e = _inject("boom", "bug", HEADMOTION_DEBUG="1")
    assert e.returncode == 4 and "Traceback" in e.stderr


def test_warnings_are_one_line_each_without_source():
    r = _inject("boom", "warn")
    assert r.returncode == 0 and r.stdout.strip() == "done"
    assert r.stderr.splitlines() == ["warning: tws-hier: too little training data for 4 clusters",
                                     "warning: RuntimeWarning: did not converge"], r.stderr
    d = _inject("boom", "warn", "--debug")   # --debug: Python's own format (file:line: Category: ...)
    assert d.returncode == 0 and ": UserWarning: tws-hier" in d.stderr and "warning: " not in d.stderr


def test_user_text_is_printed_literally():
    r = _inject("boom", "markup")
    assert_one_line_error(r, 1, "take[red].bvh", "[1, 2]", "[bold]x[/bold]")


# ------------------------------------------------------------------------ console script
def test_console_script_entry_point():
    """The console script is ``headmotion.cli:run`` (what ``python -m headmotion`` calls too)."""
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert meta["project"]["scripts"]["headmotion"] == "headmotion.cli:run"
    assert "from .cli import run" in (SRC / "headmotion" / "__main__.py").read_text()
    from importlib.metadata import entry_points

    eps = [e for e in entry_points(group="console_scripts") if e.name == "headmotion"]
    if eps:  # installed (editable or not): the installed metadata says the same
        assert eps[0].value == "headmotion.cli:run"


@pytest.mark.skipif(shutil.which("headmotion") is None, reason="the headmotion console script is not installed")
def test_installed_console_script(files, tmp_path):
    script = shutil.which("headmotion")
    r = run_cli("synth", script=script)
    assert r.returncode == 2 and "Usage: headmotion synth" in r.stderr and "Traceback" not in r.stderr
    r = run_cli("info", files["frames_1e9"], script=script)
    assert_one_line_error(r, 1, "frames_1e9.bvh", "Frames")
    r = run_cli("corpus", script=script)
    assert r.returncode == 0 and "check" in r.stdout


# ------------------------------------------------------------------------- atomic outputs
def test_failed_convert_leaves_existing_output_untouched(files, tmp_path):
    out = tmp_path / "out.csv"
    out.write_text("precious")
    r = run_cli("convert", files["frames_1e9"], out)
    assert r.returncode == 1
    assert out.read_text() == "precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]


@pytest.fixture(scope="module")
def long_bvh(tmp_path_factory):
    from headmotion.io.bvh import save_bvh

    p = tmp_path_factory.mktemp("long") / "long.bvh"
    save_bvh(_motion(T=60_000, fps=100.0), p)
    return p


@pytest.mark.slow
@pytest.mark.parametrize("delay", [2.0, 3.5, 5.0])
def test_ctrl_c_leaves_nothing_half_written(long_bvh, tmp_path, delay):
    """SIGINT at several moments of ``convert``: no partial file, the old output intact unless a
    complete new one replaced it.  (Ctrl-C during Python's own start-up, before headmotion's
    handler exists, ends with Python's KeyboardInterrupt report and exit -2; nothing is written
    then either.)"""
    out = tmp_path / "out.csv"
    out.write_text("precious")
    proc = subprocess.Popen([sys.executable, "-m", "headmotion", "convert", str(long_bvh), str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["out.csv"], names  # no .part file left
    assert proc.returncode in (0, 130, -signal.SIGINT), (proc.returncode, err)
    if proc.returncode == 130:
        assert "interrupted" in err and "Traceback" not in err
    # the old output, or (signal after the rename) the complete new one — never a part of it
    if out.read_text() != "precious":
        from headmotion.io.native import load_csv

        assert len(load_csv(out)) == 60_000


def test_interrupt_while_writing_removes_the_partial_file(tmp_path):
    """Ctrl-C in the middle of writing (KeyboardInterrupt inside the atomic block)."""
    from headmotion.io.atomic import atomic_open

    out = tmp_path / "out.csv"
    out.write_text("precious")
    with pytest.raises(KeyboardInterrupt):
        with atomic_open(out, "w") as fh:
            fh.write("half of a file")
            fh.flush()
            assert len(list(tmp_path.iterdir())) == 2  # the partial file exists meanwhile
            raise KeyboardInterrupt
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]
    assert out.read_text() == "precious"


# ------------------------------------------------------------- messages that name the user's file
SPEECH = ROOT / "examples" / "speech" / "speech_male.wav"


@pytest.fixture(scope="module")
def one_sample_wav(tmp_path_factory):
    import soundfile as sf

    p = tmp_path_factory.mktemp("short") / "click.wav"
    sf.write(p, np.zeros(1, np.float32), 16000)
    return p


@pytest.mark.parametrize("ext", [".bvh", ".npz", ".csv", ".json", ".glb"])
def test_speech_too_short_for_a_frame_names_the_file_and_writes_nothing(one_sample_wav, tmp_path, ext):
    out = tmp_path / f"head{ext}"
    r = run_cli("synth", one_sample_wav, "-o", out)
    assert_one_line_error(r, 1, str(one_sample_wav), "too short for one frame", "at least 40 ms")
    assert list(tmp_path.iterdir()) == []


def test_unwritable_output_names_the_path_asked_for(tmp_path):
    blocker = tmp_path / "not_a_folder"
    blocker.write_text("a file where a folder should be")
    out = blocker / "head.bvh"
    r = run_cli("synth", SPEECH, "-o", out)
    assert_one_line_error(r, 1, str(out))
    assert ".part" not in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["not_a_folder"]


def test_output_onto_a_folder_names_the_folder_not_the_temporary_file(tmp_path):
    from headmotion.io import save_motion

    target = tmp_path / "taken.bvh"
    (target / "inside").mkdir(parents=True)
    with pytest.raises(OSError) as info:
        save_motion(_motion(), target)
    assert info.value.filename == str(target)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken.bvh"]  # no temporary file left


def test_adapt_on_too_little_speech_names_the_folder(tmp_path):
    from headmotion.synthetic import planted_corpus

    planted_corpus(minutes=5 / 60, n_recordings=1).save(tmp_path / "corpus")
    r = run_cli("adapt", tmp_path / "corpus", "-o", tmp_path / "mine.hmz")
    assert_one_line_error(r, 2, f"error: {tmp_path / 'corpus'}: 4.5 s of speech with motion", "at least 20 s")
    assert "Corpus(" not in r.stderr
    assert not (tmp_path / "mine.hmz").exists()


@pytest.mark.parametrize("ext", [".glb", ".gltf"])
def test_info_reads_the_gltf_synth_writes(tmp_path, ext):
    out = tmp_path / f"head{ext}"
    assert run_cli("synth", SPEECH, "-o", out).returncode == 0
    r = run_cli("info", out, "--json")
    assert r.returncode == 0, r.stderr
    import json

    d = json.loads(r.stdout)
    assert d["format"] == "gltf" and d["n_frames"] == 292 and d["fps"] == 25.0


def test_piped_output_is_not_wrapped(tmp_path):
    out = tmp_path / ("a_long_output_name_" * 4 + ".bvh")
    r = run_cli("synth", SPEECH, "-o", out, COLUMNS="")
    assert r.returncode == 0, r.stderr
    first = r.stdout.splitlines()[0]
    assert len(first) > 120 and first.startswith(str(out)) and first.endswith(" deg)"), r.stdout


def test_empty_stdin_to_stream_says_so():
    r = subprocess.run([sys.executable, "-m", "headmotion", "stream"], input=b"", capture_output=True,
                       timeout=120, env=_env())
    assert r.returncode == 1, r.stderr
    err = r.stderr.decode()
    assert "Traceback" not in err and r.stdout == b""
    assert err.splitlines()[-1] == ("error: stdin: no audio arrived; expected raw 16-bit mono PCM at 16000 Hz "
                                    "(--sample-rate for another rate), e.g. `headmotion stream < speech.s16le`")


@pytest.mark.parametrize("name", ["default_model.md", "default_stream_model.md"])
def test_model_cards_cite_no_builders_paths(name):
    import re

    card = (SRC / "headmotion" / "data" / name).read_text()
    assert not re.search(r"(?<![\w.])/(work|home|root|tmp|Users|mnt)/", card), name
    assert "half a minute" not in card
    if name == "default_model.md":
        assert "(20 s or more of their speech with motion" in card


# ------------------------------------------------------------------------------- progress
def _long_speech(tmp_path, seconds: float) -> Path:
    import soundfile as sf

    x, sr = sf.read(SPEECH, dtype="float32")
    path = tmp_path / f"speech_{seconds:g}s.wav"
    sf.write(path, np.tile(x, int(seconds * sr) // len(x) + 1)[:int(seconds * sr)], sr)
    return path


def _run_with_terminal_stderr(args, tmp_path) -> tuple[int, str]:
    """``headmotion ARGS`` with stderr on a pseudo-terminal; (exit code, what the terminal showed)."""
    import pty
    import select

    master, slave = pty.openpty()
    p = subprocess.Popen([sys.executable, "-m", "headmotion", *map(str, args)], stdout=subprocess.DEVNULL,
                         stderr=slave, env=_env(COLUMNS="100"), cwd=tmp_path)
    os.close(slave)
    shown = b""
    while True:
        ready, _, _ = select.select([master], [], [], 0.2)
        if ready:
            try:
                chunk = os.read(master, 65536)
            except OSError:  # the child closed the terminal
                break
            if not chunk:
                break
            shown += chunk
        elif p.poll() is not None:
            break
    os.close(master)
    return p.wait(timeout=60), shown.decode("utf-8", "replace")


def test_synthesis_of_long_speech_shows_progress_in_a_terminal_only(tmp_path):
    speech = _long_speech(tmp_path, 75.0)
    code, shown = _run_with_terminal_stderr(["synth", speech, "-o", tmp_path / "a.bvh"], tmp_path)
    assert code == 0, shown
    assert f"synthesising {speech.name}" in shown and "100%" in shown
    assert "0:00:00" in shown  # elapsed and time left columns
    piped = run_cli("synth", speech, "-o", tmp_path / "b.bvh")
    assert piped.returncode == 0 and piped.stderr == "", piped.stderr


def test_synthesis_of_short_speech_shows_no_progress(tmp_path):
    code, shown = _run_with_terminal_stderr(["synth", SPEECH, "-o", tmp_path / "a.bvh"], tmp_path)
    assert code == 0 and "synthesising" not in shown and "%" not in shown, shown
