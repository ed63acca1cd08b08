"""Smoke test: ``benchmarks/run.py --quick`` runs and prints its table.

No timing is asserted here (speed is measured by the benchmarks, not by tests); the test checks
that every group produced a row with a figure and no group failed with an error."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_quick_benchmarks_run(tmp_path):
    out = tmp_path / "results.json"
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "run.py"), "--quick", "--out", str(out)],
                          capture_output=True, text=True, timeout=900, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "| measured" in proc.stdout and "machine:" in proc.stdout
    rows = json.loads(out.read_text())["rows"]
    groups = {r["group"].split()[0] for r in rows}
    assert {"1", "2", "3", "4", "5", "6", "8"} <= groups
    errors = [r for r in rows if r["note"].startswith("error")]
    assert not errors, errors
    assert all(r["figure"] is not None for r in rows if r["group"].startswith(("1", "2", "4", "5")))
