"""Compatibility names for ``cli/templates_cmds`` (moved by another change): tws-basic is
:mod:`headmotion.systems.tws.basic`.  Remove once nothing imports this module."""

from .tws.basic import CLASS_NAMES, TwsBasic, speed_class

__all__ = ["CLASS_NAMES", "TwsBasic", "speed_class"]
