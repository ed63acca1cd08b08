"""Command-line interface: ``headmotion COMMAND ...`` (docs/design.md "CLI")."""

from __future__ import annotations

import sys

from ..errors import HeadMotionError
from .app import app, err_console

# each module attaches its commands to the app (imported once, for that side effect, in the order
# the commands are listed by --help)
from . import io_cmds  # noqa: E402,F401,I001  info, convert
from . import features_cmds  # noqa: E402,F401  features
from . import corpus_cmds  # noqa: E402,F401  corpus check / import
from . import video_cmds  # noqa: E402,F401  corpus from-video
from . import synth_cmds  # noqa: E402,F401  train, synth
from . import stream_cmds  # noqa: E402,F401  stream
from . import templates_cmds  # noqa: E402,F401  templates encode-error / analyse / confusion
from . import eval_cmds  # noqa: E402,F401  evaluate, stats
from . import render_cmds  # noqa: E402,F401  render, view, plot
from . import listen_cmds  # noqa: E402,F401  listen serve / analyze


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``headmotion`` console script."""
    try:
        app(args=argv, prog_name="headmotion", standalone_mode=False)
    except HeadMotionError as exc:
        err_console.print(f"[bold red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return exc.exit_code
    except KeyboardInterrupt:
        err_console.print("[bold red]interrupted[/]")
        return 130
    except SystemExit as exc:  # typer/click exits (e.g. --help)
        return int(exc.code or 0)
    except Exception as exc:  # click usage errors
        import click

        if isinstance(exc, click.exceptions.ClickException):
            exc.show()
            return exc.exit_code
        if isinstance(exc, click.exceptions.Abort):
            return 1
        raise
    return 0


def run() -> None:
    sys.exit(main())


__all__ = ["app", "main", "run"]
