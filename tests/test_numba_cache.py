"""librosa's compiled functions are first used by one process at a time on a machine
(:mod:`headmotion.numba_cache`): two processes' first uses never overlap, and a second use in the
same process takes no lock."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytest.importorskip("fcntl")

CHILD = textwrap.dedent("""
    import sys, time
    from pathlib import Path
    import headmotion.numba_cache as nc

    nc.LOCK_PATH = Path(sys.argv[1])
    log, name = Path(sys.argv[2]), sys.argv[3]
    with nc.first_use("compile"):
        with open(log, "a") as fh:
            fh.write(f"{name} start\\n")
        Path(sys.argv[4]).touch()  # "I hold the lock"
        time.sleep(1.0)
        with open(log, "a") as fh:
            fh.write(f"{name} end\\n")
""")


def _start(tmp_path, name):
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.Popen([sys.executable, "-c", CHILD, str(tmp_path / "lock"), str(tmp_path / "log"), name,
                             str(tmp_path / f"{name}.holds")], env=env)


def test_first_uses_in_two_processes_do_not_overlap(tmp_path):
    a = _start(tmp_path, "a")
    for _ in range(600):  # until a holds the lock
        if (tmp_path / "a.holds").exists():
            break
        time.sleep(0.05)
    b = _start(tmp_path, "b")
    assert a.wait(timeout=120) == 0 and b.wait(timeout=120) == 0
    assert (tmp_path / "log").read_text().splitlines() == ["a start", "a end", "b start", "b end"]


def test_a_second_use_in_the_same_process_takes_no_lock(monkeypatch):
    import headmotion.numba_cache as nc

    taken = []
    real = nc._machine_lock

    def counting():
        taken.append(1)
        return real()

    monkeypatch.setattr(nc, "_machine_lock", counting)
    monkeypatch.setattr(nc, "_USED", set())
    for _ in range(3):
        with nc.first_use("something"):
            pass
    assert taken == [1]


def test_speech_onsets_use_the_lock():
    import numpy as np

    import headmotion.numba_cache as nc
    from headmotion.evaluation.measures.realism import speech_onsets
    from headmotion.types import Audio

    t = np.arange(16000) / 16000.0
    y = (np.sin(2 * np.pi * 200 * t) * (t % 0.5 < 0.1)).astype(np.float32)  # a tone every 0.5 s
    onsets = speech_onsets(Audio(y, 16000))
    assert {"import librosa", "librosa.onset.onset_detect"} <= nc._USED
    assert len(onsets) >= 1 and all(0 <= o < 1.0 for o in onsets)
