"""Repeatable ``--NAME KEY=VALUE`` options (``features --param``, ``convert --option``) as a dict."""

from __future__ import annotations

from typing import Any, Callable

from ..errors import ParameterError


def key_values(items: list[str] | None, option: str, value: Callable[[str], Any]) -> dict[str, Any]:
    """``{KEY: value(VALUE)}`` for each ``KEY=VALUE`` of ``items`` (keys stripped, ``-`` read as
    ``_``, as Python keyword arguments); a :class:`ParameterError` naming ``option`` for an item
    without ``=``."""
    out = {}
    for item in items or []:
        key, sep, raw = item.partition("=")
        if not sep:
            raise ParameterError(f"{option} expects KEY=VALUE; got {item!r}")
        out[key.strip().replace("-", "_")] = value(raw)
    return out


__all__ = ["key_values"]
