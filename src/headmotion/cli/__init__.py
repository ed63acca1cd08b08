"""Command-line interface: ``headmotion COMMAND ...`` (docs/design.md "CLI").

:func:`main` is the one place where errors become exit codes (``headmotion --help`` lists them):

* :class:`~headmotion.errors.HeadMotionError` → one line ``error: ...`` on stderr and the error's
  ``exit_code`` (1 bad input, 2 usage / bad parameter value, 3 missing optional dependency);
* click's usage errors → click's usage message and exit code 2, whichever click is installed: the
  ``click`` package or the copy typer ≥ 0.2x carries as ``typer._click`` (matched by class name,
  not by identity, so both work);
* ``OSError`` (a folder that cannot be written, a full disk) → one line, exit 1;
* a missing optional module → the extra to install, exit 3;
* anything else is a bug → one line naming it, a hint to run with ``--debug``, exit 4;
* Ctrl-C → ``interrupted``, exit 130 (writers are atomic, so no output is left half-written).

``--debug`` (anywhere on the command line, or ``HEADMOTION_DEBUG=1``) shows the traceback.
Python warnings (a model trained on little data, a library's convergence notice) print as one
``warning: ...`` line, not as a source path, line number and code line; ``--debug`` keeps
Python's format.
"""

from __future__ import annotations

import os
import sys
import warnings

from ..errors import HeadMotionError
from .app import app, err_console, print_error

# each module attaches its commands to the app (imported once, for that side effect, in the order
# the commands are listed by --help)
from . import io_cmds  # noqa: E402,F401,I001  info, convert
from . import features_cmds  # noqa: E402,F401  features
from . import corpus_cmds  # noqa: E402,F401  corpus check / import
from . import video_cmds  # noqa: E402,F401  corpus from-video
from . import synth_cmds  # noqa: E402,F401  train, synth
from . import adapt_cmds  # noqa: E402,F401  adapt
from . import stream_cmds  # noqa: E402,F401  stream
from . import templates_cmds  # noqa: E402,F401  templates encode-error / analyse / confusion
from . import eval_cmds  # noqa: E402,F401  evaluate, stats
from . import speech_eval_cmds  # noqa: E402,F401  evaluate-speech
from . import listening_eval_cmds  # noqa: E402,F401  evaluate-listening
from . import detect_cmds  # noqa: E402,F401  detect
from . import render_cmds  # noqa: E402,F401  render, view, plot
from . import listen_cmds  # noqa: E402,F401  listen serve / analyze
from . import serve_cmds  # noqa: E402,F401  serve, serve hash-key
from . import blender_cmds  # noqa: E402,F401  blender-addon
from . import robot_cmds  # noqa: E402,F401  robot reachy

#: exit codes (also in ``headmotion --help`` and :mod:`headmotion.errors`)
EXIT_BAD_INPUT, EXIT_USAGE, EXIT_MISSING_DEPENDENCY, EXIT_INTERNAL, EXIT_INTERRUPTED = 1, 2, 3, 4, 130

#: optional modules and the extra that installs them
_EXTRAS = {"mediapipe": "video", "dask": "dask", "distributed": "dask", "psycopg": "postgres",
           "psycopg_binary": "postgres", "pythonosc": "live", "sounddevice": "live", "torch": "nets"}


def _class_names(exc: BaseException) -> set[str]:
    return {c.__name__ for c in type(exc).__mro__}


def _is_click(exc: BaseException, name: str) -> bool:
    """``exc`` is click's ``name`` exception, from ``click`` or from typer's own copy."""
    return name in _class_names(exc) and any(
        c.__module__.split(".")[0] in ("click", "typer") for c in type(exc).__mro__)


def _show_usage_error(exc) -> None:
    try:
        exc.show()  # click's own "Usage: ... / Try '... --help' / Error: ..." on stderr
    except Exception:  # pragma: no cover - a click without show()
        print_error(getattr(exc, "format_message", lambda: str(exc))())


def _show_help(exc) -> int:
    """``headmotion corpus`` alone: print that group's help (stdout) and exit 0, as click < 8.2
    did (click ≥ 8.2 raises NoArgsIsHelpError instead)."""
    ctx = getattr(exc, "ctx", None)
    if ctx is None:  # pragma: no cover
        _show_usage_error(exc)
        return EXIT_USAGE
    from .app import console

    console.print(ctx.get_help(), markup=False, highlight=False, soft_wrap=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``headmotion`` console script; returns the exit code."""
    args = list(sys.argv[1:] if argv is None else argv)
    head = args[:args.index("--")] if "--" in args else args
    debug = "--debug" in head or os.environ.get("HEADMOTION_DEBUG", "") not in ("", "0")
    if "--debug" in head:
        args.remove("--debug")
    shown = warnings.showwarning
    if not debug:  # "warning: MESSAGE", not Python's "path:line: Category: message" and source line
        warnings.showwarning = _show_warning
    try:
        ret = app(args=args, prog_name="headmotion", standalone_mode=False)
    except KeyboardInterrupt:
        err_console.print("[bold red]interrupted[/]", highlight=False)
        return EXIT_INTERRUPTED
    except SystemExit as exc:  # sys.exit() in a command
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    except BrokenPipeError:  # `headmotion info x | head`
        _silence_stdout()
        return 0
    except Exception as exc:
        if debug:
            import traceback

            traceback.print_exc()
        return _handle(exc, debug)
    finally:
        warnings.showwarning = shown
    # click (standalone_mode=False) returns the exit code of ctx.exit() / typer.Exit; typer turns
    # Ctrl-C into Exit(130)
    code = ret if isinstance(ret, int) and not isinstance(ret, bool) else 0
    if code == EXIT_INTERRUPTED:
        err_console.print("[bold red]interrupted[/]", highlight=False)
    return code


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:  # noqa: ARG001
    """``warnings.showwarning`` for the command line: one ``warning: ...`` line on stderr (the
    category named unless it is a plain UserWarning); ``--debug`` keeps Python's own format."""
    from .app import print_warning

    name = getattr(category, "__name__", "Warning")
    print_warning(str(message) if name == "UserWarning" else f"{name}: {message}")


def _handle(exc: Exception, debug: bool) -> int:
    if isinstance(exc, HeadMotionError):
        print_error(exc)
        return int(getattr(exc, "exit_code", EXIT_BAD_INPUT))
    if _is_click(exc, "NoArgsIsHelpError"):
        return _show_help(exc)
    if _is_click(exc, "ClickException"):  # UsageError, BadParameter, NoSuchOption, FileError, ...
        _show_usage_error(exc)
        code = getattr(exc, "exit_code", EXIT_USAGE)
        return code if isinstance(code, int) and code else EXIT_USAGE
    if _is_click(exc, "Exit"):
        code = int(getattr(exc, "exit_code", 0) or 0)
        if code == EXIT_INTERRUPTED:
            err_console.print("[bold red]interrupted[/]", highlight=False)
        return code
    if _is_click(exc, "Abort"):  # Ctrl-C / Ctrl-D at a prompt
        err_console.print("[bold red]aborted[/]", highlight=False)
        return EXIT_INTERRUPTED
    if isinstance(exc, ModuleNotFoundError) and (exc.name or "").split(".")[0] in _EXTRAS:
        extra = _EXTRAS[exc.name.split(".")[0]]
        if extra == "nets":
            from ..devices import missing_torch

            print_error(missing_torch())
        else:
            print_error(f"this needs the optional dependency {exc.name!r}: pip install 'headmotion[{extra}]'")
        return EXIT_MISSING_DEPENDENCY
    if isinstance(exc, OSError) and not isinstance(exc, (BlockingIOError, ConnectionError)):
        where = f" {exc.filename}" if getattr(exc, "filename", None) else ""
        print_error(f"cannot access{where}: {exc.strerror or exc}")
        return EXIT_BAD_INPUT
    if isinstance(exc, MemoryError):
        print_error("out of memory; the input is larger than this machine can hold "
                    "(internal error: please report it with the command and --debug output)")
        return EXIT_INTERNAL
    msg = str(exc).splitlines()[0][:300] if str(exc) else ""
    hint = "" if debug else "; run again with --debug to see the traceback"
    print_error(f"internal error {type(exc).__name__}{': ' + msg if msg else ''} "
                f"(this is a bug in headmotion, please report it{hint})")
    return EXIT_INTERNAL


def _silence_stdout() -> None:
    try:  # Python's advice for SIGPIPE: point stdout at devnull so that exit does not fail again
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def run() -> None:
    """The console script ``headmotion`` (``[project.scripts]`` in pyproject.toml)."""
    sys.exit(main())


__all__ = ["app", "main", "run", "EXIT_BAD_INPUT", "EXIT_USAGE", "EXIT_MISSING_DEPENDENCY",
           "EXIT_INTERNAL", "EXIT_INTERRUPTED"]
