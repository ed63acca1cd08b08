"""The CLI's rich consoles: markup that never swallows text, and no wrapping when piped.

Imported on a console's first use (:data:`headmotion.cli.app.console`): rich's console module is
~20 ms of a command's start, and ``headmotion stream`` prints nothing before its first frame.
"""

from __future__ import annotations

import os
import sys

from rich.console import Console
from rich.markup import RE_TAGS
from rich.style import Style

from .terminal import is_terminal


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


def make_console(*, stderr: bool = False) -> SafeConsole:
    """A console that wraps at the terminal's width, and not at all when its stream is piped or
    redirected (rich would wrap at 80 columns there; ``COLUMNS`` still sets a width)."""
    piped = not is_terminal(sys.stderr if stderr else sys.stdout)
    if piped and not os.environ.get("COLUMNS"):
        return SafeConsole(stderr=stderr, soft_wrap=True, width=UNWRAPPED_WIDTH)
    return SafeConsole(stderr=stderr)


#: the width a piped console lays tables out in (lines are not wrapped at all)
UNWRAPPED_WIDTH = 10_000


__all__ = ["SafeConsole", "make_console", "UNWRAPPED_WIDTH"]
