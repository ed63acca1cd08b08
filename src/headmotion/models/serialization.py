"""Model files without pickle: a ``.hmz`` zip of ``config.json`` + ``arrays.npz`` (docs/design.md "Model files").

``config.json`` records the system name, its parameters, the feature configuration, the package
version and a summary of the training corpus; ``arrays.npz`` holds every learned array (numpy
arrays, torch ``state_dict`` tensors converted to numpy) and is read with ``allow_pickle=False``, so
loading a model file can never run code (scikit-learn's persistence notes; asteroid's
``serialize()``).  A damaged, truncated or foreign file raises
:class:`~headmotion.errors.ModelFileError`; a file from another package version warns.
"""

from __future__ import annotations

import io
import json
import warnings
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelFileError
from ..io.atomic import atomic_path

FORMAT = "headmotion-model"
FORMAT_VERSION = 1


def _package_version() -> str:
    from .. import __version__

    return __version__


def save_model_file(path, *, system: str, config: dict[str, Any], arrays: dict[str, np.ndarray]) -> Path:
    """Write a model file atomically.

    Parameters
    ----------
    path : path of the ``.hmz`` file
    system : the registry name of the system (e.g. ``"tws-hier"``)
    config : JSON-serialisable parameters, feature configuration, corpus summary, …
    arrays : name → array; names may contain ``/`` and ``.`` (e.g. torch state-dict keys)
    """
    path = Path(path)
    header = {"format": FORMAT, "format_version": FORMAT_VERSION, "system": system,
              "headmotion_version": _package_version(), **config}
    try:
        text = json.dumps(header, indent=2, sort_keys=True, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"model config for {system!r} is not JSON-serialisable: {exc}") from exc
    buf = io.BytesIO()
    clean = {}
    for k, v in arrays.items():
        a = np.asarray(v)
        if a.dtype == object:
            raise ModelFileError(f"array {k!r} has dtype object; only numeric arrays can be saved")
        clean[k] = a
    np.savez_compressed(buf, **clean)
    with atomic_path(path) as tmp:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_STORED) as zf:
            zf.writestr("config.json", text)
            zf.writestr("arrays.npz", buf.getvalue())
    return path


def load_model_file(path, *, expect_system: str | None = None) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Read a model file: ``(config, arrays)``.

    Raises ModelFileError when the file is missing, not a headmotion model, damaged or truncated,
    or (with ``expect_system``) made for another system."""
    path = Path(path)
    if not path.exists():
        raise ModelFileError(f"{path}: model file not found")
    try:
        with zipfile.ZipFile(path) as zf:
            names = set(zf.namelist())
            if "config.json" not in names or "arrays.npz" not in names:
                raise ModelFileError(
                    f"{path}: not a headmotion model (expected config.json and arrays.npz inside; found {sorted(names)[:5]})")
            config = json.loads(zf.read("config.json").decode("utf-8"))
            with np.load(io.BytesIO(zf.read("arrays.npz")), allow_pickle=False) as npz:
                arrays = {k: npz[k] for k in npz.files}
    except ModelFileError:
        raise
    except (zipfile.BadZipFile, EOFError, OSError, ValueError, KeyError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{path}: damaged or truncated model file ({type(exc).__name__}: {exc})") from exc
    if not isinstance(config, dict) or config.get("format") != FORMAT:
        raise ModelFileError(f"{path}: not a headmotion model file (config.json has no format {FORMAT!r})")
    if int(config.get("format_version", 0)) > FORMAT_VERSION:
        raise ModelFileError(
            f"{path}: model file format {config.get('format_version')} is newer than this headmotion "
            f"understands ({FORMAT_VERSION}); upgrade headmotion")
    if expect_system is not None and config.get("system") != expect_system:
        raise ModelFileError(
            f"{path}: this is a {config.get('system')!r} model, not a {expect_system!r} model")
    saved = config.get("headmotion_version")
    if saved != _package_version():
        warnings.warn(f"{path} was saved by headmotion {saved}; this is {_package_version()}", stacklevel=2)
    return config, arrays


__all__ = ["save_model_file", "load_model_file"]
