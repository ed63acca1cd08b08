"""Compatibility names for code not yet moved to :mod:`headmotion.systems.tws` (``cli/templates_cmds``
imports ``collect`` from here); remove once nothing imports this module."""

from .tws.vectors import collect

__all__ = ["collect"]
