"""System specifications with parameters: ``NAME[KEY=VALUE;KEY=VALUE]`` (the command line's way to
set what :meth:`~headmotion.systems.base.Synthesizer.set_params` sets in Python).

``headmotion train --system "mfcc-dnn[drift_share=0.3]"`` trains with that parameter and
``headmotion evaluate --systems "mfcc-dnn,mfcc-dnn[drift_share=0.3]"`` compares the two settings in
one report, each row labelled by its specification (``;`` or ``,`` separate parameters inside the
brackets; a list value keeps its own brackets: ``regressor_hidden=[512,512]``).  Values are read as JSON when they parse
(``0.3``, ``true``, ``null``, ``[1, 2]``) and kept as text otherwise (``features=mfcc``).  A
parameter the system does not have is refused when the specification is read, naming the system,
the key and the parameters it has.

Neither seed defines a syntax for this; the bracket form follows the ``name[option]`` habit of
pip's extras, and ``;`` separates parameters because ``,`` separates systems.  Library
considered: ``argparse``/``typer`` take one option per value, which cannot say which of several
systems in one evaluation a value belongs to.
"""

from __future__ import annotations

import json
import re
from typing import Any

from ..errors import ParameterError

_SPEC = re.compile(r"^\s*([A-Za-z0-9_.\-]+)\s*(?:\[(.*)\])?\s*$", re.S)


def _split_top(text: str, seps: str) -> list[str]:
    """Split ``text`` at the characters ``seps`` outside brackets and braces (a JSON list or
    object value keeps its commas)."""
    out, depth, cur = [], 0, []
    for ch in str(text):
        if ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
            if depth < 0:
                raise ParameterError(f"unbalanced ']' in {text!r}")
        if ch in seps and depth == 0:
            out.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    if depth:
        raise ParameterError(f"unbalanced '[' in {text!r}")
    out.append("".join(cur))
    return [s.strip() for s in out if s.strip()]


def split_systems(text: str) -> list[str]:
    """``"a,b[x=1;y=2],c"`` → ``["a", "b[x=1;y=2]", "c"]``: commas inside brackets do not split."""
    return _split_top(text, ",")


def _value(text: str) -> Any:
    try:
        return json.loads(text)
    except ValueError:
        return text


def parse_system(text: str) -> tuple[str, dict[str, Any]]:
    """``"mfcc-dnn[drift_share=0.3;idle=null]"`` → ``("mfcc-dnn", {"drift_share": 0.3, "idle": None})``.

    The name must be a registered system and every key one of its parameters."""
    from .base import system_class

    m = _SPEC.match(str(text))
    if not m:
        raise ParameterError(f"expected a system as NAME or NAME[KEY=VALUE;...]; got {text!r}")
    name, body = m.group(1), m.group(2)
    params: dict[str, Any] = {}
    if body is not None:
        for part in _split_top(body, ";,"):
            if "=" not in part:
                raise ParameterError(f"{text!r}: expected KEY=VALUE inside the brackets; got {part.strip()!r}")
            k, v = (x.strip() for x in part.split("=", 1))
            if not k:
                raise ParameterError(f"{text!r}: a parameter needs a name before '='; got {part.strip()!r}")
            params[k] = _value(v)
    if params:
        try:  # an unknown key (set_params) or a bad value is refused now, not after minutes of training
            system_class(name)().set_params(**params)._validate_params()
        except ParameterError as exc:
            raise ParameterError(f"{text!r}: {exc}") from None
    return name, params


def label(name: str, params: dict[str, Any]) -> str:
    """The canonical text of a specification (sorted keys, JSON values): ``name[a=1;b=true]``."""
    if not params:
        return name
    return name + "[" + ";".join(f"{k}={json.dumps(params[k])}" for k in sorted(params)) + "]"


class SystemFactory:
    """A picklable ``() -> Synthesizer`` for one specification (what ``evaluate`` takes as the
    factory of a ``(label, factory)`` pair; worker processes rebuild the system from it)."""

    def __init__(self, name: str, params: dict[str, Any]):
        self.name, self.params = name, dict(params)

    def __call__(self):
        from .base import create

        return create(self.name, **self.params)

    def __repr__(self) -> str:
        return f"SystemFactory({label(self.name, self.params)!r})"


__all__ = ["split_systems", "parse_system", "label", "SystemFactory"]
