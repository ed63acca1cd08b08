"""Evaluation conditions: everything ``evaluate`` scores, behind one contract (thesis §4.3.1, §5.9
Table 5.8: systems are compared with the ground truth and anchors in one table).

A :class:`Condition` is fitted on a fold's training recordings and then makes the motion of one
held-out recording with a seed:

* ``fit(corpus) -> self`` — learn from the training recordings (an anchor stores their motion;
  a system trains; a model file needs nothing and ignores them);
* ``motion_for(recording, *, seed) -> Motion`` — the condition's motion for the recording;
* declared, not sniffed: ``needs_other_speakers`` (fit it on the other speakers' recordings),
  ``sampled`` (the diversity measure draws several motions per recording from it),
  ``reachable_range()`` (the pose range it declares, for the saturation measure),
  ``embedding`` / ``embed()`` (a learned speech embedding scored against the motion),
  ``reference`` (the recording's own motion: gets the reference-only scores) and
  ``fit_warnings`` (what training had to say, for the report).

The conditions:

* :class:`SystemCondition` — a :class:`~headmotion.systems.base.Synthesizer` trained on the fold:
  ``motion_for`` is ``predict(recording.audio, seed=seed)``;
* :class:`ModelFileCondition` — a model file, scored as it is, without training;
* :class:`FittedCondition` — a model fitted before the folds, scored as a model file is;
* the anchors of :mod:`.anchors` (ground truth, desync, shifted, other speaker, shaped noise,
  still), which make their motion from the recordings' data, not from speech.

:mod:`.condition_specs` turns the names ``headmotion evaluate --systems`` takes into conditions.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Callable

import numpy as np

from ...errors import ParameterError
from ...types import Motion

#: the name of the reference condition, the recording's own motion
GROUND_TRUTH = "ground-truth"


class Condition(ABC):
    """One evaluation condition: fitted on a corpus, gives the motion for one recording."""

    #: the condition's name in the report
    name: str = ""
    #: fit on the *other* speakers' recordings (the evaluation arranges it)
    needs_other_speakers: bool = False
    #: the diversity measure draws several motions per recording from it
    sampled: bool = False
    #: the recording's own motion (the reference the others are measured against)
    reference: bool = False
    #: it has a learned speech embedding (``embed``)
    embedding: bool = False

    @abstractmethod
    def fit(self, corpus) -> "Condition":
        """Learn from the training recordings; returns ``self``."""

    @abstractmethod
    def motion_for(self, recording, *, seed: int | None = None) -> Motion:
        """The condition's motion for ``recording``."""

    def reachable_range(self) -> np.ndarray | None:
        """The pose range the condition can reach, ``(3, 2)`` radians, or None (none declared)."""
        return None

    def embed(self, audio, *, fps: float, n_frames: int):  # noqa: ARG002  (the optional hook)
        """The learned speech embedding of ``audio``; only conditions whose ``embedding`` is True
        have one (the scoring asks no other)."""
        raise ParameterError(f"condition {self.name!r} has no learned speech embedding (its `embedding` is False)")

    @property
    def fit_warnings(self) -> list[str]:
        """What fitting reported beyond Python warnings (e.g. fewer clusters on a short fold)."""
        return []


class SystemCondition(Condition):
    """A synthesis system trained on the fold; its motion is ``predict`` on the recording's speech.

    Parameters
    ----------
    name : str — the name in the report
    make : callable ``() -> Synthesizer`` — a new, unfitted system
    random_state : int | None — its training seed, set when the system has that parameter
    """

    def __init__(self, name: str, make: Callable, random_state: int | None = None):
        self.name = name
        self.model = make()
        if random_state is not None and "random_state" in self.model.get_params():
            self.model.set_params(random_state=random_state)

    @property
    def needs_other_speakers(self) -> bool:  # type: ignore[override]
        from ...systems.base import NEEDS_OTHER_SPEAKERS

        return NEEDS_OTHER_SPEAKERS in self.model.capabilities

    @property
    def sampled(self) -> bool:  # type: ignore[override]
        """Every system not declared deterministic (``stochastic="none"``)."""
        return self.model.get_params().get("stochastic", None) != "none"

    @property
    def embedding(self) -> bool:  # type: ignore[override]
        from ...systems.base import EMBEDDING

        return EMBEDDING in self.model.capabilities

    def fit(self, corpus) -> "SystemCondition":
        self.model.fit(corpus)
        return self

    def motion_for(self, recording, *, seed: int | None = None) -> Motion:
        return self.model.predict(recording.audio, seed=seed)

    def reachable_range(self) -> np.ndarray | None:
        return self.model.reachable_range()

    def embed(self, audio, *, fps: float, n_frames: int):
        return self.model.embed(audio, fps=fps, n_frames=n_frames)

    @property
    def fit_warnings(self) -> list[str]:
        return list(getattr(self.model, "fit_warnings_", None) or [])


class ModelFileCondition(SystemCondition):
    """A trained model file, scored as it is: ``fit`` leaves it unchanged, so every fold scores the
    same model on its held-out recordings.

    Parameters
    ----------
    name : str — the name in the report
    path : path of the ``.hmz`` file
    """

    def __init__(self, name: str, path):
        from ...systems.base import load_model

        self.path = path
        super().__init__(name, lambda: load_model(path))

    @property
    def needs_other_speakers(self) -> bool:  # type: ignore[override]
        return False  # trained already: whichever recordings the fold trains on do not matter

    def fit(self, corpus) -> "ModelFileCondition":  # noqa: ARG002  (trained already)
        return self


class FittedCondition(ModelFileCondition):
    """A model fitted before the folds (a level built once on the evaluated corpus,
    :mod:`.levels`), scored as it is in every fold, as a model file is.

    Parameters
    ----------
    name : str — the name in the report
    model : a fitted Synthesizer
    """

    def __init__(self, name: str, model):
        self.path = None
        SystemCondition.__init__(self, name, lambda: model)


__all__ = ["GROUND_TRUTH", "Condition", "SystemCondition", "ModelFileCondition", "FittedCondition"]
