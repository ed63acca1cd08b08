"""Template-warping synthesis, tws-basic and tws-hier (thesis ch. 5): :mod:`.basic`, :mod:`.hier`,
sharing :mod:`.base` (the system skeleton), :mod:`.features`, :mod:`.vectors`, :mod:`.limits` and
:mod:`.generator`."""

from .basic import TwsBasic
from .hier import TwsHier

__all__ = ["TwsBasic", "TwsHier"]
