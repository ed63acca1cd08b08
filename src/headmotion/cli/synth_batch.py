"""``headmotion synth IN... -o DIR``: many inputs, one motion file each (:mod:`headmotion.batch`).

``synth`` takes this form when it is given several inputs, a folder or ``@LIST``, an output
without an extension (a folder), or any of ``--format``, ``--jobs``, ``--scheduler``,
``--force``.  A progress bar on stderr (when it is a terminal) counts the files with their rate
and the time left; each damaged input is one ``error:`` line naming it; the run ends with one
summary line and exit code 0, or 1 when an input failed (4 when one met a bug).
"""

from __future__ import annotations

import sys
from pathlib import Path

from ..errors import ParameterError
from .app import console, err_console, print_error
from .terminal import is_terminal


def is_batch(speech: list[Path], output: Path, fmt, jobs, scheduler, force: bool) -> bool:
    """Whether ``synth``'s arguments ask for the batch form (see the module docstring)."""
    if len(speech) > 1 or fmt is not None or jobs is not None or scheduler is not None or force:
        return True
    first = str(speech[0])
    return first.startswith("@") or Path(first).is_dir() or output.suffix == "" or output.is_dir()


def _files_per_second():
    """A progress column of files per second (rich is imported here, by the batch form only: a
    single ``synth`` does not pay for it)."""
    from rich.progress import ProgressColumn
    from rich.text import Text

    class FilesPerSecond(ProgressColumn):
        def render(self, task) -> Text:
            speed = task.finished_speed or task.speed
            return Text("" if speed is None else f"{speed:.1f} files/s")

    return FilesPerSecond()


def run_batch(speech: list[Path], output: Path, *, model, fmt, jobs, scheduler, force: bool, seed, samples: int,
              neck_share, controls, video) -> int:
    """Run the batch with a progress bar and a summary; returns the exit code."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from ..batch import synthesize_batch

    if video is not None:
        raise ParameterError("--video previews one input; give one speech file and an output file to make a video")
    fmt = fmt or "bvh"
    bar = Progress(TextColumn("[bold]synth"), BarColumn(), MofNCompleteColumn(), _files_per_second(),
                   TimeRemainingColumn(), console=err_console.get(), transient=False, disable=not is_terminal(sys.stderr))
    task = None

    def progress(done: int, total: int) -> None:
        nonlocal task
        if task is None:  # started once the workers are running (they fork without the bar's thread)
            bar.start()
            task = bar.add_task("synth", total=total)
        bar.update(task, completed=done)

    def report(_source, status: str, message: str) -> None:
        if status == "failed":
            print_error(message)

    try:
        res = synthesize_batch(speech, output, model="default" if model is None else model, format=fmt,
                               jobs=1 if jobs is None else jobs, scheduler=scheduler, force=force, seed=seed,
                               samples=samples, neck_share=neck_share, controls=controls, progress=progress,
                               report=report)
    finally:
        bar.stop()
    rate = f" ({len(res.written) / res.seconds:.1f} files/s)" if res.written and res.seconds > 0 else ""
    console.print(f"wrote {len(res.written)}, up to date {len(res.skipped)}, failed {len(res.failed)} of "
                  f"{res.total} inputs in {res.seconds:.1f} s{rate} → {output}", highlight=False, soft_wrap=True)
    return res.exit_code


__all__ = ["is_batch", "run_batch"]
