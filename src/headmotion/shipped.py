"""The models shipped inside the package, by name.

``default`` is the offline model ``headmotion synth`` uses; ``stream`` is the causal model
``headmotion stream`` and the live page use (it also synthesises offline).  Each lives in
``headmotion/data/`` as ``<file>.hmz`` with its model card ``<file>.md`` beside it.  Wherever a
model is taken (``-m``, ``--model``, :func:`headmotion.load_model`) a shipped name or a file path
is accepted; :func:`resolve_model_path` turns either into the file.  This module reads no model
file and imports nothing heavy.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from .errors import ModelFileError

#: shipped name → file in ``headmotion/data``
SHIPPED_FILES = {"default": "default_model.hmz", "stream": "default_stream_model.hmz"}


@dataclass(frozen=True)
class ShippedModel:
    """A model shipped in the package: its name, its file and one line of its card."""

    name: str
    path: Path
    summary: str


def data_dir() -> Path:
    """The package's data folder (``headmotion/data``)."""
    return Path(__file__).resolve().parent / "data"


def shipped_path(name: str) -> Path:
    """The file of the shipped model ``name`` (``default`` or ``stream``).

    Raises :class:`~headmotion.errors.ModelFileError` on an unknown name, or when the file is
    missing from this installation."""
    if name not in SHIPPED_FILES:
        raise ModelFileError(f"no shipped model is named {name!r}; the shipped models are "
                             f"{', '.join(SHIPPED_FILES)}")
    path = data_dir() / SHIPPED_FILES[name]
    if not path.is_file():
        raise ModelFileError(f"{path}: the shipped model {name!r} is missing from this installation; "
                             "give a model file instead")
    return path


def resolve_model_path(model) -> Path:
    """The model file meant by ``model``: a shipped name (``default``, ``stream``) or a path.

    A bare shipped name wins over a file of that name in the working folder (write ``./default``
    for the file).  Raises :class:`~headmotion.errors.ModelFileError` when ``model`` is neither a
    shipped name nor an existing file, listing the shipped names."""
    text = str(model)
    if isinstance(model, str) and text in SHIPPED_FILES:
        return shipped_path(text)
    path = Path(model)
    if not path.exists():
        from .registry import SYSTEMS  # a plain table: importing it loads no system

        hint = (f"; {text!r} is a system, not a model: train one with `headmotion train CORPUS --system {text} "
                f"-o mine.hmz`" if text in SYSTEMS else "")
        raise ModelFileError(f"model {text!r} is neither a shipped model ({', '.join(SHIPPED_FILES)}) nor an "
                             f"existing model file; `headmotion models` lists the shipped ones{hint}")
    return path


def card_path(model_file) -> Path:
    """The model card beside a model file: the same name with ``.md``."""
    return Path(model_file).with_suffix(".md")


def card_summary(model_file) -> str:
    """One line from a model card: its title (less "Model card: ") and the system it names."""
    card = card_path(model_file)
    if not card.is_file():
        return "(no model card)"
    text = card.read_text(encoding="utf-8")
    title = next((ln.lstrip("#").strip() for ln in text.splitlines() if ln.startswith("#")), card.stem)
    title = re.sub(r"^model card:\s*", "", title, flags=re.IGNORECASE)
    system = re.search(r"\*\*System\*\*:\s*`([^`]+)`", text)
    return f"{system.group(1)}: {title}" if system else title


def list_models() -> list[ShippedModel]:
    """The shipped models present in this installation, in the order of :data:`SHIPPED_FILES`."""
    out = []
    for name, file in SHIPPED_FILES.items():
        path = data_dir() / file
        if path.is_file():
            out.append(ShippedModel(name, path, card_summary(path)))
    return out


__all__ = ["SHIPPED_FILES", "ShippedModel", "card_path", "card_summary", "data_dir", "list_models",
           "resolve_model_path", "shipped_path"]
