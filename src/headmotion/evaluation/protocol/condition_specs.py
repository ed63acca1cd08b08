"""What ``headmotion evaluate --systems`` names, resolved to evaluation conditions (:mod:`.conditions`).

One entry of the list is, in this order of precedence:

1. ``NAME[KEY=VALUE;...]`` — a registered system with parameters
   (:mod:`headmotion.systems.spec`), trained on every fold;
2. an anchor name (:data:`.anchors.ANCHORS`: ``ground-truth``, ``desync``, ``shifted``, …);
3. a registered system name (``tws-hier``, ``mfcc-dnn``, …), trained on every fold;
4. a shipped model name (:data:`SHIPPED_MODELS`): ``default`` is the package's
   ``data/default_model.hmz``, ``stream`` its ``data/default_stream_model.hmz``;
5. the path of a model file (``mine.hmz``).

A shipped model or a model file is scored as it is, without training: it has no folds of its own
and is scored on every held-out recording of every fold, so its rows line up with the trained
systems'.  A registered system name always means training that system (a system registered as
``default`` would be trained, not the shipped file read).  In Python an entry may also be a
``(name, factory)`` pair, ``factory()`` returning an unfitted system.

Seeds: every condition's training and synthesis seeds derive from its *seed name* — its name,
except that a system with parameters uses its plain system name, so that settings compared in one
evaluation differ only by the setting (a paired comparison).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ...errors import ParameterError
from ...shipped import SHIPPED_FILES as SHIPPED_MODELS  # shipped name → file (the one registry)
from ...shipped import shipped_path as shipped_model_path  # the file of a shipped model, by name


@dataclass(frozen=True)
class ConditionSpec:
    """A picklable description of one condition (shipped to the fold workers, which make it).

    ``kind`` is ``"anchor"`` (``target`` = anchor name), ``"system"`` (``target`` = a callable
    returning an unfitted system), ``"model"`` (``target`` = model file path) or ``"fitted"``
    (``target`` = a model fitted before the folds, e.g. a level of :mod:`.levels`)."""

    name: str
    kind: str
    target: Any
    seed_name: str

    def make(self, random_state: int | None = None):
        """A new, unfitted condition; ``random_state`` is a trained system's training seed."""
        from .anchors import create_anchor
        from .conditions import FittedCondition, ModelFileCondition, SystemCondition

        makers = {
            "anchor": lambda: create_anchor(self.target, random_state),
            "system": lambda: SystemCondition(self.name, self.target, random_state),
            "model": lambda: ModelFileCondition(self.name, self.target),
            "fitted": lambda: FittedCondition(self.name, self.target),
        }
        return makers[self.kind]()


def _model_file(name: str, path: Path) -> ConditionSpec:
    from ...systems.base import load_model

    if not path.is_file():
        raise ParameterError(f"model file {path} not found (a --systems entry that is neither a system, an "
                             f"anchor nor a shipped model is read as a model file)")
    load_model(path)  # a damaged or foreign file fails now (ModelFileError), not in every fold
    return ConditionSpec(name, "model", str(path.resolve()), name)


def condition_spec(entry) -> ConditionSpec:
    """The condition an entry of ``evaluate``'s ``systems`` names (see the module docstring);
    ParameterError for an unknown name, naming what is accepted."""
    from ...systems.base import SYSTEMS
    from ...systems.spec import SystemFactory, label, parse_system

    from .anchors import ANCHORS

    if isinstance(entry, tuple) and len(entry) == 2 and isinstance(entry[0], str) and callable(entry[1]):
        name, factory = entry
        seed_name = factory.name if isinstance(factory, SystemFactory) else name
        return ConditionSpec(name, "system", factory, seed_name)
    if not isinstance(entry, (str, Path)):
        raise ParameterError(f"a system must be a registry name, a model file or a (name, factory) pair; "
                             f"got {entry!r}")
    text = str(entry)
    if "[" in text:
        name, params = parse_system(text)
        return ConditionSpec(label(name, params), "system", SystemFactory(name, params), name)
    if text in ANCHORS:
        return ConditionSpec(text, "anchor", text, text)
    if text in SYSTEMS:
        return ConditionSpec(text, "system", SystemFactory(text, {}), text)
    if text in SHIPPED_MODELS:
        return _model_file(text, shipped_model_path(text))
    if text.endswith(".hmz") or Path(text).is_file():
        return _model_file(text, Path(text))
    raise ParameterError(f"unknown system {text!r}; expected a system ({', '.join(sorted(SYSTEMS))}), an anchor "
                         f"({', '.join(sorted(ANCHORS))}), a shipped model ({', '.join(sorted(SHIPPED_MODELS))}) "
                         f"or the path of a model file (.hmz)")


__all__ = ["ConditionSpec", "condition_spec", "SHIPPED_MODELS", "shipped_model_path"]
