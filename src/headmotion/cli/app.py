"""The typer application and its sub-command groups; command modules attach to these.

The CLI is thin (docs/design.md "CLI"): it parses, calls the package, shows rich progress bars and turns
:class:`~headmotion.errors.HeadMotionError` into one clear line on stderr and a non-zero exit code.
Heavy libraries are imported inside commands so that ``headmotion --help`` stays fast.
"""

from __future__ import annotations

import contextlib
import os
import sys

import typer
from rich.console import Console
from rich.markup import RE_TAGS, escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.style import Style

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


def _is_style_tag(tag: str) -> bool:
    """Whether a markup tag body (``bold red``, ``/``, ``/bold``, ``link=...``) is a rich style."""
    body = tag[1:] if tag.startswith("/") else tag
    if not body or body.startswith(("link=", "@")):
        return True
    try:
        Style.parse(body)
    except Exception:
        return False
    return True


def _escape_non_styles(text: str) -> str:
    """Escape every ``[...]`` that is not a rich style, so that ``pip install headmotion[video]``,
    ``[0, 1]`` or ``take[3].bvh`` print with their brackets while ``[bold]...[/]`` still works."""
    def fix(m):
        backslashes, tag = m.group(2), m.group(3)
        if backslashes or _is_style_tag(tag):
            return m.group(0)
        return "\\" + m.group(0)

    return RE_TAGS.sub(fix, text)


class SafeConsole(Console):
    """A rich console whose markup never swallows text: square brackets that do not name a style
    are printed as they are.  Messages that interpolate user text should
    still pass it through :func:`escape` (a file named ``take[red].bvh``)."""

    def render_str(self, text: str, *args, **kwargs):
        markup = kwargs.get("markup")
        if (self._markup if markup is None else markup) and "[" in text:
            text = _escape_non_styles(text)
        return super().render_str(text, *args, **kwargs)


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # replaced or closed
        return False


def _console(*, stderr: bool = False) -> SafeConsole:
    """A console that wraps at the terminal's width, and not at all when its stream is piped or
    redirected (rich would wrap at 80 columns there; ``COLUMNS`` still sets a width)."""
    piped = not _is_terminal(sys.stderr if stderr else sys.stdout)
    if piped and not os.environ.get("COLUMNS"):
        return SafeConsole(stderr=stderr, soft_wrap=True, width=UNWRAPPED_WIDTH)
    return SafeConsole(stderr=stderr)


#: the width a piped console lays tables out in (lines are not wrapped at all)
UNWRAPPED_WIDTH = 10_000

console = _console()
err_console = _console(stderr=True)


def print_error(message: str) -> None:
    """``error: MESSAGE`` on stderr, the message printed literally (no markup)."""
    err_console.print(f"[bold red]error:[/] {escape(str(message))}", highlight=False, soft_wrap=True)


def print_warning(message: str) -> None:
    """``warning: MESSAGE`` on stderr, the message printed literally (no markup)."""
    err_console.print(f"[yellow]warning:[/] {escape(str(message))}", highlight=False, soft_wrap=True)


@contextlib.contextmanager
def progress_bar(description: str, total: float | None = None, *, min_total: float | None = None):
    """A rich progress bar with the time left; yields ``update(done, total=None, description=None)``.

    Rendered on stderr only when it is a terminal, so piped output stays clean; with ``min_total``,
    only for work of at least that ``total`` (short work finishes before a bar would say anything)."""
    short = min_total is not None and not (total is not None and total >= min_total)
    progress = Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(), TimeRemainingColumn(), console=err_console, transient=False,
        disable=short or not _is_terminal(sys.stderr),
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
