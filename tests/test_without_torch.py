"""What the base install (no PyTorch: torch is the ``nets`` extra) does: synthesis, streaming, the
service, evaluation of the shipped models, ``adapt`` and the tws / le2012 systems never import torch,
and the network systems exit 3 naming the extra.

Each case runs in a child process whose ``sys.meta_path`` refuses ``torch`` (as a machine without it
would), with this checkout's ``src`` first on the path.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SPEECH = ROOT / "examples" / "speech" / "speech_male.wav"

#: the child's first lines: torch cannot be imported, whatever is installed
BLOCK_TORCH = textwrap.dedent("""
    import sys

    class _NoTorch:
        def find_spec(self, name, path=None, target=None):
            if name == "torch" or name.startswith("torch."):
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return None

    sys.meta_path.insert(0, _NoTorch())
""")


def run_without_torch(code: str, *, timeout: float = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""),
               COLUMNS="200", NO_COLOR="1", HEADMOTION_DEBUG="")
    return subprocess.run([sys.executable, "-c", BLOCK_TORCH + textwrap.dedent(code)], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=ROOT)


def test_the_block_refuses_torch():
    r = run_without_torch("""
        try:
            import torch  # noqa: F401
        except ModuleNotFoundError:
            print("refused")
    """)
    assert r.stdout.strip() == "refused", r.stderr


def run_cli_without_torch(*args, stdin: bytes | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    """``headmotion ARGS`` in a child process that cannot import torch."""
    code = "from headmotion.cli import main; sys.exit(main(sys.argv[1:]))"
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""),
               COLUMNS="200", NO_COLOR="1", HEADMOTION_DEBUG="")
    return subprocess.run([sys.executable, "-c", BLOCK_TORCH + code, *map(str, args)], input=stdin,
                          capture_output=True, timeout=timeout, env=env, cwd=ROOT)


def test_stream_from_stdin_without_torch():
    import soundfile as sf

    x, sr = sf.read(SPEECH, dtype="int16")
    r = run_cli_without_torch("stream", stdin=x[:2 * sr].tobytes())
    assert r.returncode == 0, r.stderr
    frames = [json.loads(ln) for ln in r.stdout.decode().splitlines()]
    assert len(frames) == 50  # 2 s at the stream model's 25 frames a second
    assert frames[-1]["frame"] == 49


def test_synth_adapt_train_and_evaluate_never_import_torch(tmp_path):
    """The command line's torch-free work, in one process that cannot import torch."""
    r = run_without_torch(f"""
        import json, sys
        from headmotion.cli import main
        from headmotion.synthetic import planted_corpus

        tmp = {str(tmp_path)!r}
        codes = {{}}
        codes["synth"] = main(["synth", {str(SPEECH)!r}, "-o", tmp + "/h.bvh"])
        codes["synth_stream_model"] = main(["synth", {str(SPEECH)!r}, "-m", "stream", "-o", tmp + "/s.npz"])
        planted_corpus(minutes=0.8, n_recordings=2, speakers=("a", "b")).save(tmp + "/corpus")
        codes["adapt"] = main(["adapt", tmp + "/corpus", "-o", tmp + "/mine.hmz"])
        codes["train_tws"] = main(["train", tmp + "/corpus", "--system", "tws-basic[n_components=1;n_init=1]",
                                   "-o", tmp + "/tws.hmz"])
        codes["train_le2012"] = main(["train", tmp + "/corpus", "--system",
                                      "le2012[n_components=2;max_train_frames=2000;n_steps=4]", "-o", tmp + "/le.hmz"])
        codes["synth_tws"] = main(["synth", {str(SPEECH)!r}, "-m", tmp + "/tws.hmz", "-o", tmp + "/t.csv"])
        codes["evaluate"] = main(["evaluate", tmp + "/corpus", "--systems", "default,stream,desync",
                                  "-o", tmp + "/report"])
        print(json.dumps({{"codes": codes, "torch": "torch" in sys.modules}}))
    """, timeout=600)
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["codes"] == {k: 0 for k in out["codes"]}, r.stderr
    assert out["torch"] is False
    assert (tmp_path / "h.bvh").read_text().startswith("HIERARCHY")
    for name in ("s.npz", "mine.hmz", "tws.hmz", "le.hmz", "t.csv", "report/metrics.csv"):
        assert (tmp_path / name).is_file(), name
    # the evaluation says once that the detectability test ran without its network classifier
    assert r.stderr.count("PyTorch is not installed") == 1, r.stderr


@pytest.mark.parametrize("system", ["cccae", "mfcc-dnn", "ae-dnn", "motion-flow"])
def test_network_systems_exit_3_naming_the_extra(tmp_path, system):
    r = run_without_torch(f"""
        import sys
        from headmotion.synthetic import planted_corpus
        from headmotion.cli import main

        planted_corpus(minutes=0.5, n_recordings=2).save({str(tmp_path / "c")!r})
        sys.exit(main(["train", {str(tmp_path / "c")!r}, "--system", {system!r}, "-o", {str(tmp_path / "m.hmz")!r}]))
    """)
    assert r.returncode == 3, (r.stdout, r.stderr)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), r.stderr
    assert "needs PyTorch" in lines[0] and "pip install 'headmotion[nets]'" in lines[0]
    assert "torch==2.13.0" in lines[0]
    assert not (tmp_path / "m.hmz").exists()


def test_service_answers_without_torch():
    """The service's app (as ``headmotion serve`` builds it) answers a speech file with motion."""
    r = run_without_torch(f"""
        import json, sys, time
        from fastapi.testclient import TestClient
        from headmotion.serve.app import create_app
        from headmotion.serve.config import ServeConfig

        with TestClient(create_app(ServeConfig()), base_url="http://127.0.0.1") as client:
            for _ in range(600):  # the models load in the background at startup
                if client.get("/readyz").status_code == 200:
                    break
                time.sleep(0.1)
            res = client.post("/v1/motion?format=json", content=open({str(SPEECH)!r}, "rb").read(),
                              headers={{"content-type": "audio/wav"}})
        body = res.json()
        print(json.dumps({{"status": res.status_code, "fps": body["fps"], "n": len(body["frames"]),
                          "torch": "torch" in sys.modules}}))
    """)
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out == {"status": 200, "fps": 25.0, "n": 292, "torch": False}, r.stderr


def test_detectability_network_alone_names_the_extra():
    r = run_without_torch("""
        import numpy as np
        from headmotion.errors import MissingDependencyError
        from headmotion.evaluation.detection.detectability import detectability

        rng = np.random.default_rng(0)
        real = {f"r{i}": rng.normal(size=(400, 3)) * 0.05 for i in range(4)}
        try:
            detectability(real, real, fps=25.0, classifiers=("cnn",), n_boot=10)
        except MissingDependencyError as exc:
            print(exc.exit_code, exc)
    """)
    assert r.stdout.startswith("3 the detectability test's network classifier needs PyTorch"), r.stderr
