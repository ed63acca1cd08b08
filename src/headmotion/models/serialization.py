"""Model files without pickle: a ``.hmz`` zip of ``config.json`` + ``arrays.npz`` (docs/design.md "Model files").

``config.json`` records the system name, its parameters, the feature configuration, the package
version and a summary of the training corpus; ``arrays.npz`` holds every learned array (numpy
arrays, torch ``state_dict`` tensors converted to numpy) and is read with ``allow_pickle=False``, so
loading a model file can never run code (scikit-learn's persistence notes; asteroid's
``serialize()``).  A damaged, truncated or foreign file raises
:class:`~headmotion.errors.ModelFileError`; a file from another package version warns.

Reading checks before it trusts: the zip's member list and each member's
declared size are checked before anything is decompressed (``config.json`` at most 16 MiB,
``arrays.npz`` at most 4 GiB, and every array's header against its member's size —
:func:`headmotion.io._limits.load_npz_arrays`), members are read through a bounded reader so a
zip bomb cannot expand past its declared size, and ``config.json`` (nesting and integer length
bounded) is checked against :data:`CONFIG_SCHEMA`: the keys every model file carries, with their
types.  The systems check their own parameters when they rebuild themselves.
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
MAX_CONFIG_BYTES = 16 << 20
MAX_ARRAYS_BYTES = 4 << 30

#: key -> (accepted types, required) for config.json
CONFIG_SCHEMA: dict[str, tuple[tuple[type, ...], bool]] = {
    "format": ((str,), True),
    "format_version": ((int,), True),
    "system": ((str,), True),
    "headmotion_version": ((str,), False),
    "corpus": ((dict, type(None)), False),
    "params": ((dict,), False),
    "features": ((str, list, dict, type(None)), False),
    "feature_config": ((dict, type(None)), False),
}


def check_config(config: Any, path) -> dict[str, Any]:
    """``config`` against :data:`CONFIG_SCHEMA`; ModelFileError naming the key otherwise."""
    if not isinstance(config, dict):
        raise ModelFileError(f"{path}: config.json must hold a JSON object; found {type(config).__name__}")
    if config.get("format") != FORMAT:
        raise ModelFileError(f"{path}: not a headmotion model file (config.json has no format {FORMAT!r})")
    for key, (types, required) in CONFIG_SCHEMA.items():
        if key not in config:
            if required:
                raise ModelFileError(f"{path}: config.json lacks {key!r}; expected a headmotion model file")
            continue
        v = config[key]
        if not isinstance(v, types) or isinstance(v, bool):
            want = " or ".join("null" if t is type(None) else t.__name__ for t in types)
            raise ModelFileError(f"{path}: config.json {key!r} is {v!r:.60}; expected {want}")
    if not config["system"].strip():
        raise ModelFileError(f"{path}: config.json 'system' is empty; expected a system name")
    return config


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
    from ..io._limits import load_json, load_npz_arrays
    from ..errors import FormatError

    path = Path(path)
    if not path.exists():
        raise ModelFileError(f"{path}: model file not found")
    if not path.is_file():
        raise ModelFileError(f"{path}: is not a file; expected a .hmz model file")
    try:
        with zipfile.ZipFile(path) as zf:
            infos = {i.filename: i for i in zf.infolist()}
            if "config.json" not in infos or "arrays.npz" not in infos:
                raise ModelFileError(
                    f"{path}: not a headmotion model (expected config.json and arrays.npz inside; found {sorted(infos)[:5]})")
            for name, limit in (("config.json", MAX_CONFIG_BYTES), ("arrays.npz", MAX_ARRAYS_BYTES)):
                info = infos[name]
                if info.file_size > 100 * info.compress_size + (1 << 20):  # save_model_file stores them
                    raise ModelFileError(f"{path}: {name} would expand {info.file_size} bytes from "
                                         f"{info.compress_size} (a zip bomb?); not a model file")
                if infos[name].file_size > limit:  # checked before decompressing
                    raise ModelFileError(f"{path}: {name} declares {infos[name].file_size} bytes; at most "
                                         f"{limit} accepted (damaged or not a model file)")
            with zf.open(infos["config.json"]) as fh:
                raw = fh.read(MAX_CONFIG_BYTES + 1)
            if len(raw) > MAX_CONFIG_BYTES:
                raise ModelFileError(f"{path}: config.json is larger than {MAX_CONFIG_BYTES} bytes")
            try:
                config = load_json(raw, path=path, what="config.json")
            except FormatError as exc:
                raise ModelFileError(str(exc)) from None
            check_config(config, path)
            with zf.open(infos["arrays.npz"]) as fh, _Spool(fh, infos["arrays.npz"].file_size, path) as spool:
                arrays = load_npz_arrays(spool, path=path, max_bytes=MAX_ARRAYS_BYTES, error=ModelFileError)
    except ModelFileError:
        raise
    except (zipfile.BadZipFile, EOFError, OSError, ValueError, KeyError, UnicodeDecodeError,
            NotImplementedError, RuntimeError) as exc:
        raise ModelFileError(f"{path}: damaged or truncated model file ({type(exc).__name__}: {exc})") from None
    try:
        version = int(config["format_version"])
    except (TypeError, ValueError, OverflowError):
        raise ModelFileError(f"{path}: format_version {config.get('format_version')!r} is not a number") from None
    if version > FORMAT_VERSION:
        raise ModelFileError(
            f"{path}: model file format {version} is newer than this headmotion "
            f"understands ({FORMAT_VERSION}); upgrade headmotion")
    if expect_system is not None and config.get("system") != expect_system:
        raise ModelFileError(
            f"{path}: this is a {config.get('system')!r} model, not a {expect_system!r} model")
    saved = config.get("headmotion_version")
    if saved != _package_version():
        warnings.warn(f"{path} was saved by headmotion {saved}; this is {_package_version()}", stacklevel=2)
    return config, arrays


def _Spool(fh, size: int, path=None):
    """The inner ``arrays.npz`` as a seekable file (zipfile needs to seek), read at most ``size``
    bytes (its declared size, already bounded) into a spooled temporary file, which the caller
    closes."""
    import tempfile

    tmp = tempfile.SpooledTemporaryFile(max_size=64 << 20)
    try:
        left = size
        while True:
            chunk = fh.read(min(1 << 20, left + 1))
            if not chunk:
                break
            left -= len(chunk)
            if left < 0:
                raise ModelFileError(f"{path}: arrays.npz holds more data than its declared size")
            tmp.write(chunk)
    except BaseException:
        tmp.close()
        raise
    tmp.seek(0)
    return tmp  # the caller closes it (a context manager)


__all__ = ["save_model_file", "load_model_file", "check_config", "CONFIG_SCHEMA"]
