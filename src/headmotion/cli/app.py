"""The typer application and its sub-command groups; command modules attach to these.

The CLI is thin (docs/design.md "CLI"): it parses, calls the package, shows rich progress bars and turns
:class:`~headmotion.errors.HeadMotionError` into one clear line on stderr and a non-zero exit code.
Heavy libraries are imported inside commands so that ``headmotion --help`` stays fast.
"""

from __future__ import annotations

import contextlib
import sys

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

app = typer.Typer(
    name="headmotion",
    help="Natural head motion from speech: synthesis, training, evaluation, rendering.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
corpus_app = typer.Typer(help="Build and check corpora (speech + head motion).", no_args_is_help=True)
templates_app = typer.Typer(help="Template analysis (thesis §5.1–5.3).", no_args_is_help=True)
listen_app = typer.Typer(help="Subjective tests: serve and analyse.", no_args_is_help=True)
app.add_typer(corpus_app, name="corpus")
app.add_typer(templates_app, name="templates")
app.add_typer(listen_app, name="listen")

console = Console()
err_console = Console(stderr=True)


@contextlib.contextmanager
def progress_bar(description: str, total: float | None = None):
    """A rich progress bar; yields ``update(done, total=None, description=None)``.

    Rendered on stderr only when it is a terminal, so piped output stays clean."""
    progress = Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(), TimeRemainingColumn(), console=err_console, transient=False,
        disable=not sys.stderr.isatty(),
    )
    with progress:
        task = progress.add_task(description, total=total)

        def update(done: float, total: float | None = None, description: str | None = None):
            kw = {"completed": done}
            if total is not None:
                kw["total"] = total
            if description is not None:
                kw["description"] = description
            progress.update(task, **kw)

        yield update
