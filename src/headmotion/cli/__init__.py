"""Command-line interface: ``headmotion COMMAND ...`` (DESIGN.md "CLI")."""

from __future__ import annotations

import sys

from ..errors import HeadMotionError
from .app import app, err_console

# each module attaches its commands to the app (imports are for their side effect)
_COMMAND_MODULES = (
    "io_cmds",         # info, convert
    "features_cmds",   # features
    "corpus_cmds",     # corpus check / import
    "video_cmds",      # corpus from-video
    "synth_cmds",      # train, synth, stream
    "templates_cmds",  # templates encode-error / analyse
    "eval_cmds",       # evaluate, stats
    "render_cmds",     # render, view, plot
    "listen_cmds",     # listen serve / analyze
)


def _attach_commands() -> None:
    import importlib

    for name in _COMMAND_MODULES:
        try:
            importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:  # during development a module may not exist yet
            if exc.name != f"{__name__}.{name}":
                raise


_attach_commands()


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
