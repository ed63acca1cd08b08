"""Compatibility names for ``cli/templates_cmds`` (moved by another change): the template-warping
code is in :mod:`headmotion.systems.tws`.  Remove with ``tws_basic`` once nothing imports them."""

from .tws.vectors import collect

__all__ = ["collect"]
