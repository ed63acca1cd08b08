"""The models a worker serves: each file read once when the worker starts and shared by every
request and stream of that worker (a model is read-only at synthesis; each stream holds only its
own state).  Cards for ``GET /v1/models`` are computed once, with the models."""

from __future__ import annotations

import time
from pathlib import Path

from ..errors import ParameterError
from . import engine


class UnknownModel(ParameterError):
    """A request names a model this server does not have."""


class Registry:
    """Name → loaded model and its card."""

    def __init__(self, files: dict[str, Path], *, default_stream: str = engine.DEFAULT_STREAM):
        engine.check_loaded(files)
        self.files = dict(files)
        self.default_stream = default_stream  # the model of a stream whose start message names none
        self.models: dict = {}
        self.cards: dict[str, dict] = {}
        self.load_seconds = 0.0
        self.error: str | None = None

    @classmethod
    def of_loaded(cls, name: str, model, path: Path | None = None) -> "Registry":
        """A registry of one model already loaded (``view --live``, an agent's own server), the
        default of every stream; ``path`` its file when it has one (for its card)."""
        reg = cls({name: path or Path(name)}, default_stream=name)
        reg.cards[name] = engine.card(name, model, path)
        reg.models[name] = model
        return reg

    def load_all(self) -> "Registry":
        t0 = time.perf_counter()
        for name, path in self.files.items():
            model = engine.load(path)
            self.cards[name] = engine.card(name, model, path)
            self.models[name] = model  # last: ``ready`` is true once every model has its card
        self.load_seconds = time.perf_counter() - t0
        return self

    @property
    def ready(self) -> bool:
        return len(self.models) == len(self.files)

    def check_ready(self) -> None:
        """503 while the models load (or when loading failed)."""
        if not self.ready:
            from .access import ApiError

            raise ApiError(503, "not_ready", self.error or "the models are still loading; try again shortly "
                                                         "(GET /readyz says when)", {"retry-after": "2"})

    def get(self, name: str | None, *, default: str, streaming: bool = False):
        """The model called ``name`` (``default`` when None), or UnknownModel listing the names."""
        self.check_ready()
        name = default if name is None else str(name)
        if name not in self.models:
            raise UnknownModel(f"unknown model {name!r}; this server has {sorted(self.models)}")
        model = self.models[name]
        if streaming and not model.can_stream:
            streamers = sorted(n for n, c in self.cards.items() if c["streams"])
            raise UnknownModel(f"model {name!r} cannot stream; models that stream: {streamers}")
        return name, model


__all__ = ["Registry", "UnknownModel"]
