"""The typer application and its sub-command groups; command modules attach to these.

The CLI is thin (docs/design.md "CLI"): it parses, calls the package, shows rich progress bars and turns
:class:`~headmotion.errors.HeadMotionError` into one clear line on stderr and a non-zero exit code.
Heavy libraries are imported inside commands so that ``headmotion --help`` stays fast.
"""

from __future__ import annotations

import contextlib
import sys

import typer

from .terminal import is_terminal

HELP = """Natural head motion from speech: synthesis, training, evaluation, rendering.

Exit codes: 0 success, 1 bad input (a missing or damaged file), 2 usage error, 3 missing optional
dependency, 4 internal error, 130 interrupted.  Add --debug to any command to see the full
traceback of an error."""

app = typer.Typer(
    name="headmotion",
    help=HELP,
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


class _OnFirstUse:
    """A console (:func:`.consoles.make_console`) made when it is first used: a command that prints
    nothing before its work (``headmotion stream``'s first frame) does not wait for rich."""

    def __init__(self, *, stderr: bool):
        self._stderr, self._console = stderr, None

    def get(self):
        """The console itself (for rich's own classes, e.g. a Progress)."""
        if self._console is None:
            from .consoles import make_console

            self._console = make_console(stderr=self._stderr)
        return self._console

    def __getattr__(self, name):
        return getattr(self.get(), name)


console = _OnFirstUse(stderr=False)
err_console = _OnFirstUse(stderr=True)


def escape(text: str) -> str:
    """``text`` with rich markup escaped, printed literally (:func:`rich.markup.escape`, imported
    on first use)."""
    from rich.markup import escape as rich_escape

    return rich_escape(text)


def print_error(message: str) -> None:
    """``error: MESSAGE`` on stderr, the message printed literally (no markup)."""
    err_console.print(f"[bold red]error:[/] {escape(str(message))}", highlight=False, soft_wrap=True)


def print_warning(message: str) -> None:
    """``warning: MESSAGE`` on stderr, the message printed literally (no markup)."""
    err_console.print(f"[yellow]warning:[/] {escape(str(message))}", highlight=False, soft_wrap=True)


def _no_bar(done: float, total: float | None = None, description: str | None = None) -> None:  # noqa: ARG001
    """``progress_bar``'s update when no bar is shown."""


@contextlib.contextmanager
def progress_bar(description: str, total: float | None = None, *, min_total: float | None = None):
    """A rich progress bar with the time left; yields ``update(done, total=None, description=None)``.

    Rendered on stderr only when it is a terminal, so piped output stays clean; with ``min_total``,
    only for work of at least that ``total`` (short work finishes before a bar would say anything)."""
    short = min_total is not None and not (total is not None and total >= min_total)
    if short or not is_terminal(sys.stderr):   # no bar: rich's progress module (~40 ms) is not imported
        yield _no_bar
        return
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    progress = Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(), TimeRemainingColumn(), console=err_console.get(), transient=False,
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
