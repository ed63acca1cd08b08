"""Declared parameter constraints, checked by one function (scikit-learn's
``_parameter_constraints`` manner): a system lists what each parameter may be, and every refusal
reads alike — ``the 'hop' parameter of motion-match must be a whole number >= 1; got 0``.

A parameter's entry is a list of what it may be; it is accepted when it satisfies any of them:

* :class:`Interval` — a whole (``int``) or real (``float``) number in a range (booleans are not
  numbers here; a real number must be finite);
* :class:`Options` — one of some values (strings);
* :data:`BOOLEAN` — True or False (numpy's too); :data:`SIZES` — a network's layer sizes;
* ``None`` — None.

Relations between parameters (e.g. motion-flow's prefix below half its window) stay in the
system's ``_validate_params``, after :func:`check_params`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral, Real
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import ParameterError


@dataclass(frozen=True)
class Interval:
    """A number from ``lo`` to ``hi`` (None: unbounded); ``closed``: which ends belong to it
    (``"both"``, ``"left"``, ``"right"``, ``"neither"``); ``kind``: ``int`` (a whole number) or
    ``float`` (any finite number, whole ones included)."""

    kind: type
    lo: float | None = None
    hi: float | None = None
    closed: str = "both"

    def __call__(self, v: Any) -> bool:
        if isinstance(v, (bool, np.bool_)):
            return False
        if self.kind is int:
            if not isinstance(v, Integral):
                return False
        elif not isinstance(v, Real) or not math.isfinite(float(v)):
            return False
        left = self.closed in ("both", "left")
        right = self.closed in ("both", "right")
        if self.lo is not None and not (v >= self.lo if left else v > self.lo):
            return False
        return self.hi is None or (v <= self.hi if right else v < self.hi)

    def describe(self) -> str:
        what = "a whole number" if self.kind is int else "a number"
        lo, hi = self.lo, self.hi
        if lo is not None and hi is not None:
            if self.closed == "both":
                return f"{what} from {lo:g} to {hi:g}"
            return f"{what} in {'[' if self.closed in ('both', 'left') else '('}{lo:g}, {hi:g}" \
                   f"{']' if self.closed in ('both', 'right') else ')'}"
        if lo is not None:
            return f"{what} {'>=' if self.closed in ('both', 'left') else '>'} {lo:g}"
        if hi is not None:
            return f"{what} {'<=' if self.closed in ('both', 'right') else '<'} {hi:g}"
        return what


@dataclass(frozen=True)
class Options:
    """One of ``values``."""

    values: tuple

    def __call__(self, v: Any) -> bool:
        try:
            return v in self.values
        except TypeError:  # an unhashable or odd value is not one of them
            return False

    def describe(self) -> str:
        return f"one of {list(self.values)}"


@dataclass(frozen=True)
class _Boolean:
    def __call__(self, v: Any) -> bool:
        return isinstance(v, (bool, np.bool_))

    def describe(self) -> str:
        return "True or False"


#: True or False
BOOLEAN = _Boolean()


@dataclass(frozen=True)
class _Sizes:
    def __call__(self, v: Any) -> bool:
        try:
            return all(not isinstance(h, (bool, np.bool_)) and int(h) == h and h >= 1 for h in v)
        except (TypeError, ValueError):
            return False

    def describe(self) -> str:
        return "a sequence of layer sizes >= 1"


#: a network's hidden layer sizes: a sequence of whole numbers >= 1
SIZES = _Sizes()


def _describe(c) -> str:
    return "None" if c is None else c.describe()


def _satisfies(c, v) -> bool:
    return v is None if c is None else bool(c(v))


def check_params(system, constraints: Mapping[str, Sequence]) -> None:
    """Raise :class:`ParameterError` for the first parameter of ``system`` that satisfies none of
    its constraints, naming the parameter, the system, what it may be and the value."""
    for name, allowed in constraints.items():
        v = getattr(system, name)
        if not any(_satisfies(c, v) for c in allowed):
            may = " or ".join(_describe(c) for c in allowed)
            raise ParameterError(f"the {name!r} parameter of {system.name} must be {may}; got {v!r:.60}")


def whole(lo: int | None = None, hi: int | None = None) -> Interval:
    """A whole number from ``lo`` to ``hi``."""
    return Interval(int, lo, hi)


def real(lo: float | None = None, hi: float | None = None, closed: str = "both") -> Interval:
    """A finite number from ``lo`` to ``hi`` (``closed``: which ends belong)."""
    return Interval(float, lo, hi, closed)


__all__ = ["Interval", "Options", "BOOLEAN", "SIZES", "check_params", "whole", "real"]
