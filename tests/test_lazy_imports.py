"""Commands import only what they use: ``headmotion --help``, ``info``, ``convert`` and ``synth`` with
the shipped models leave PyTorch, matplotlib, numba/librosa, fastapi, mediapipe and scipy.signal
unimported, and writing motion (``synth``, ``stream``) does not import scipy.spatial (an import
check in a fresh process, not a timing).  The shipped models read pitch with Praat (parselmouth);
the commands that make no motion do not import it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("torch", "matplotlib", "numba", "librosa", "fastapi", "mediapipe", "scipy.signal", "scipy.stats",
         "sklearn")
#: the pitch tracker the shipped models read the speech with: only commands that make motion load it
PITCH = ("parselmouth",)
RUN = """
import json, sys
from headmotion.cli import main
try:
    rc = main(sys.argv[1:])
except SystemExit as exc:
    rc = exc.code
print(json.dumps({"rc": rc, "modules": sorted(sys.modules)}), file=sys.stderr)
"""


def _modules(*args: str) -> set[str]:
    out = subprocess.run([sys.executable, "-c", RUN, *args], capture_output=True, text=True, timeout=300)
    report = json.loads(out.stderr.strip().splitlines()[-1])
    assert report["rc"] in (0, None), out.stderr
    return set(report["modules"])


def _loaded(mods: set[str], names) -> list[str]:
    return [n for n in names if n in mods]


def test_help_imports_no_numerical_library():
    mods = _modules("--help")
    assert _loaded(mods, HEAVY + PITCH + ("numpy", "scipy", "soundfile")) == []


@pytest.mark.parametrize("model", [None, "default_stream_model.hmz"])
def test_synth_imports_neither_torch_nor_plotting_nor_servers(tmp_path, examples_dir, model):
    out = tmp_path / "m.bvh"
    args = ["synth", str(examples_dir / "speech" / "speech_male.wav"), "-o", str(out)]
    if model is not None:
        args += ["-m", str(ROOT / "src" / "headmotion" / "data" / model)]
    mods = _modules(*args)
    assert out.exists() and out.stat().st_size > 1000          # it did synthesise
    assert "headmotion.systems.motion_match" in mods or model is not None
    assert _loaded(mods, HEAVY + ("scipy.spatial",)) == []


def test_stream_imports_no_scipy(examples_dir):
    import numpy as np

    from headmotion.io import load_audio

    x = load_audio(examples_dir / "speech" / "short.wav", sample_rate=16000).samples
    pcm = (np.clip(x, -1, 1) * 32767).astype("<i2").tobytes()
    model = ROOT / "src" / "headmotion" / "data" / "default_stream_model.hmz"
    out = subprocess.run([sys.executable, "-c", RUN, "stream", "-m", str(model), "--input", "-", "--sample-rate",
                          "16000"], input=pcm, capture_output=True, timeout=300)
    report = json.loads(out.stderr.decode().strip().splitlines()[-1])
    assert report["rc"] in (0, None), out.stderr.decode()[-2000:]
    assert len(out.stdout.decode().splitlines()) > 60                       # frames came out (2.8 s at 25 fps)
    assert _loaded(set(report["modules"]), HEAVY + ("scipy",)) == []


def test_info_and_convert_import_no_heavy_library(tmp_path, examples_dir):
    bvh = tmp_path / "m.bvh"
    _modules("synth", str(examples_dir / "speech" / "short.wav"), "-o", str(bvh))
    for args in (["info", str(examples_dir / "speech" / "short.wav")], ["info", str(bvh)],
                 ["convert", str(bvh), str(tmp_path / "m.csv")]):
        assert _loaded(_modules(*args), HEAVY + PITCH) == [], args
    assert "scipy.spatial" not in _modules("info", str(examples_dir / "speech" / "short.wav"))
    assert (tmp_path / "m.csv").exists()


def test_long_input_read_in_blocks_imports_no_torch(tmp_path, examples_dir):
    """A recording long enough to be read block by block goes through the default's stream, which
    must not import torch either (the threshold is lowered so that the bundled speech is long)."""
    code = (
        "import json, sys\n"
        "from headmotion.systems import long_input\n"
        "long_input.LONG_INPUT_SECONDS = 1.0\n"
        "from headmotion import synthesis\n"
        f"assert synthesis.reads_in_blocks(synthesis.load_model('default'), {str(examples_dir / 'speech' / 'speech_male.wav')!r})\n"
        f"m = synthesis.synthesize({str(examples_dir / 'speech' / 'speech_male.wav')!r})[0]\n"
        "assert len(m) > 100\n"
        "print(json.dumps(sorted(sys.modules)))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    mods = set(json.loads(out.stdout.strip().splitlines()[-1]))
    assert _loaded(mods, HEAVY) == []
