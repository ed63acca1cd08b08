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
    try:
        proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "run.py"), "--quick", "--out", str(out)],
                              capture_output=True, text=True, timeout=900, cwd=ROOT)
    except subprocess.TimeoutExpired as exc:  # the rows printed so far say which groups finished
        so_far = exc.stdout.decode(errors="replace") if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        pytest.fail(f"benchmarks/run.py --quick ran past {exc.timeout:g} s (a loaded machine?); the groups after "
                    f"the last row printed did not finish:\n{so_far[-3000:]}")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "| measured" in proc.stdout and "machine:" in proc.stdout
    rows = json.loads(out.read_text())["rows"]
    errors = [f"{r['group']}: {r['note']}" for r in rows if r["note"].startswith("error")]
    assert not errors, "groups that failed:\n" + "\n".join(errors)
    groups = {r["group"].split()[0] for r in rows}
    missing = sorted({"1", "2", "3", "4", "5", "6", "8"} - groups, key=int)
    assert not missing, f"groups with no row: {missing}; the run's output ends:\n{proc.stdout[-3000:]}"
    no_figure = [f"{r['group']}: {r['what']} ({r['note']})" for r in rows
                 if r["group"].startswith(("1", "2", "4", "5")) and r["figure"] is None]
    assert not no_figure, "rows without a figure:\n" + "\n".join(no_figure)


def test_a_failing_group_is_reported_under_its_label(tmp_path, monkeypatch):
    """A group that raises (a terminated worker, say) gets one row under its table label with the
    error, so the smoke test above names the group and the reason."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import run as bench

    def broken(res, quick):  # noqa: ARG001
        raise RuntimeError("a worker process was terminated")

    monkeypatch.setattr(bench, "bench_evaluate", broken)
    out = tmp_path / "results.json"
    assert bench.main(["--only", "evaluate", "--out", str(out)]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert [(r["group"], r["note"]) for r in rows] == [
        ("8 evaluate", "error: RuntimeError: a worker process was terminated")]
    assert set(bench.LABELS) == set(bench.GROUPS)
