"""Measurement helpers for ``benchmarks/run.py``: machine description, warm-up + median timing,
peak memory of a child process, and the result table.

Figures are ratios to real time (audio seconds ÷ compute seconds) wherever a duration of speech
is involved, so that they compare across machines.
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable


def machine() -> dict:
    model = platform.processor() or "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cores": os.cpu_count(), "cpu": model, "python": platform.python_version(),
            "platform": platform.platform()}


def time_median(fn: Callable[[], object], *, repeats: int = 3, warmup: int = 1) -> float:
    """Median wall time of ``fn()`` in seconds after ``warmup`` untimed calls."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


#: the child's own peak RSS in MB: the kernel's high-water mark of its address space (VmHWM).
#: ``getrusage(RUSAGE_SELF).ru_maxrss`` is not that on Linux: exec keeps the larger of the old and
#: the new image's peak, so a child forked from a benchmark process holding 1 GB reports 1 GB
#: whatever it does itself.
PEAK_RSS_CODE = (
    "def _peak_rss_mb():\n"
    "    try:\n"
    "        with open('/proc/self/status') as f:\n"
    "            return next(int(l.split()[1]) for l in f if l.startswith('VmHWM:')) / 1024.0\n"
    "    except (OSError, StopIteration):\n"
    "        import resource\n"
    "        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0\n"
)


def on_local_cluster(fn: Callable[[str], object], *, workers: int = 2):
    """``(fn(scheduler_address), seconds)`` on a fresh Dask ``LocalCluster`` of ``workers``
    single-thread processes, started as the README recommends for headmotion's work (without
    Dask's 64 kB ``MALLOC_TRIM_THRESHOLD_``: docs/decisions/cluster-workers.md); None when
    dask.distributed is not installed."""
    try:
        import dask
        from dask.distributed import Client, LocalCluster
    except ImportError:
        return None
    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}), \
            LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        t0 = time.perf_counter()
        out = fn(client.scheduler.address)
        return out, time.perf_counter() - t0


def peak_rss_of(code: str, *, timeout: float = 1800) -> tuple[float, str]:
    """Run ``code`` in a fresh Python process; return (its own peak RSS in MB, its stdout)."""
    wrapper = (
        PEAK_RSS_CODE
        + f"exec(compile({code!r}, '<bench>', 'exec'))\n"
        "print('__RSS__', _peak_rss_mb())\n"
    )
    out = subprocess.run([sys.executable, "-c", wrapper], capture_output=True, text=True, timeout=timeout)
    if out.returncode != 0:
        raise RuntimeError(f"benchmark child failed:\n{out.stderr[-2000:]}")
    rss = float(next(l for l in out.stdout.splitlines() if l.startswith("__RSS__")).split()[1])
    return rss, out.stdout


@dataclass
class Row:
    group: str
    what: str
    figure: float | None
    unit: str
    target: str = ""
    passed: bool | None = None
    note: str = ""

    def cells(self) -> list[str]:
        fig = "n/a" if self.figure is None else (f"{self.figure:,.1f}" if abs(self.figure) >= 10 else f"{self.figure:.3g}")
        ok = {True: "PASS", False: "FAIL", None: "-"}[self.passed]
        return [self.group, self.what, f"{fig} {self.unit}".strip(), self.target, ok, self.note]


@dataclass
class Results:
    machine: dict = field(default_factory=machine)
    rows: list[Row] = field(default_factory=list)

    def add(self, row: Row) -> Row:
        row.figure = None if row.figure is None else float(row.figure)  # numpy scalars → JSON
        row.passed = None if row.passed is None else bool(row.passed)
        self.rows.append(row)
        print("  " + " | ".join(row.cells()), flush=True)
        return row

    def table(self) -> str:
        head = ["#", "measured", "figure", "target", "result", "note"]
        body = [r.cells() for r in self.rows]
        widths = [max(len(str(x)) for x in col) for col in zip(head, *body)]
        fmt = lambda cells: "| " + " | ".join(str(c).ljust(w) for c, w in zip(cells, widths)) + " |"
        lines = [f"machine: {self.machine['cores']} cores, {self.machine['cpu']}, Python {self.machine['python']}",
                 fmt(head), "|" + "|".join("-" * (w + 2) for w in widths) + "|"]
        lines += [fmt(c) for c in body]
        return "\n".join(lines)

    def save(self, path) -> None:
        Path(path).write_text(json.dumps({"machine": self.machine, "rows": [asdict(r) for r in self.rows]}, indent=2))
