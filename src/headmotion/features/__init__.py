"""Speech features at a chosen frame rate, aligned to motion (paper §4.1, §4.3; thesis §2.2.4,
§2.3, §5.5.1, §5.7.1).

Every feature set is a time-first :class:`~headmotion.types.FeatureTrack` at ``fps`` (100 by
default) with one name per column; frame ``t`` is the analysis window centred on
``(t + 0.5) / fps``.  ``n_frames`` forces the length (trim, or repeat the last frame) so that
features line up with a motion track; by default it is :func:`headmotion.align.n_frames` of the
audio.

===========  ====  =======================================================  ================
name         dims  what                                                     module
===========  ====  =======================================================  ================
``f0e``      6     log F0 + energy (dB), 10-frame smoothing, Δ, ΔΔ (paper)  :mod:`.prosody`
``mfcc``     39    energy + 12 mel cepstra, Δ, ΔΔ (paper, HTK recipe)       :mod:`.spectral`
``fbank``    27    26 log mel bands + log energy (paper §4.3)               :mod:`.spectral`
``wav``      100   4 kHz waveform, 25 ms windows (paper, CCCAE input)       :mod:`.waveform`
``lsp``      16    line spectral frequencies, LPC order 16 (thesis §5.7.1)  :mod:`.lpc`
``lar``      16    log area ratios (thesis §5.7.1)                          :mod:`.lpc`
``prosody``  2     openSMILE-like pitch (semitones) + loudness (Le et al.)  :mod:`.prosody`
===========  ====  =======================================================  ================

Streaming variants (:mod:`.streaming`): ``f0e-live`` (6 dims, the ``f0e`` columns from
a per-frame YIN with short-lookahead smoothing and deltas; final 64 ms after a frame's start) and
``prosody-live`` (2 dims, ``prosody``'s pitch and intensity loudness; 24 ms).  Computed offline
by the same code that streams them, so streamed and offline values are identical.

Audio at any rate is first resampled to ``analysis_rate`` (16 kHz, thesis §3.4) with soxr, so
features do not depend on the recording's rate (``wav`` resamples straight to 4 kHz).

Registry: :func:`register` adds a Python extractor, :func:`register_file` an externally computed
track (e.g. EMA from speech inversion, thesis §5.7.1), :func:`available` lists the names.
:class:`FeatureConfig` is the serialisable (name, fps, params) a model stores;
:class:`~headmotion.features.normalize.Normalizer` the per-dimension normalisation.
Speech activity: :mod:`headmotion.features.vad`.

Heavy libraries (parselmouth, soxr; librosa only for ``lsp``/``lar`` with ``method="burg"``) are
imported only when a feature is computed.  CPU time on 60 s of 16 kHz speech (one core): ``wav``
~0.01 s, ``mfcc``/``fbank``/``lar`` ~0.04–0.06 s, ``f0e`` ~0.11 s, ``prosody`` ~0.14 s, ``lsp``
~0.2 s — all ≥ 200× real time (measured on a shared, loaded 2-core machine).
"""

from __future__ import annotations

import importlib
import inspect
import json
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import numpy as np

from ..errors import ParameterError
from ..types import Audio, FeatureTrack, check_rate
from .normalize import Normalizer

DEFAULT_FPS = 100.0
ANALYSIS_RATE = 16000

# name -> ("module:function", analysis rate or None to keep the audio's rate)
_BUILTIN: dict[str, tuple[str, int | None]] = {
    "f0e": ("prosody:f0e", ANALYSIS_RATE),
    "mfcc": ("spectral:mfcc", ANALYSIS_RATE),
    "fbank": ("spectral:fbank", ANALYSIS_RATE),
    "wav": ("waveform:wav", None),
    "lsp": ("lpc:lsp", ANALYSIS_RATE),
    "lar": ("lpc:lar", ANALYSIS_RATE),
    "prosody": ("prosody:prosody", ANALYSIS_RATE),
    "f0e-live": ("readers:f0e_live", ANALYSIS_RATE),
    "prosody-live": ("streaming:prosody_live", ANALYSIS_RATE),
}
_REGISTRY: dict[str, Callable[..., Any]] = {}


def _builtin(name: str) -> Callable[..., Any]:
    target, _ = _BUILTIN[name]
    mod, fn = target.split(":")
    return getattr(importlib.import_module(f"{__name__}.{mod}"), fn)


def available() -> list[str]:
    """Names of every feature set that :func:`extract` accepts."""
    return sorted(set(_BUILTIN) | set(_REGISTRY))


def register(name: str, fn: Callable[..., Any], *, overwrite: bool = False) -> None:
    """Add a feature extractor.

    Parameters
    ----------
    name : str
    fn : callable ``fn(audio, *, fps, n_frames, **params)`` returning a FeatureTrack, a
        ``(values (T, D), names)`` pair, or an array ``(T, D)``.
    overwrite : bool, replace an existing registration (built-ins cannot be replaced)
    """
    if not isinstance(name, str) or not name.strip():
        raise ParameterError(f"feature name must be a non-empty string; got {name!r}")
    if not callable(fn):
        raise ParameterError(f"register({name!r}, fn): fn must be callable; got {type(fn).__name__}")
    if name in _BUILTIN:
        raise ParameterError(f"{name!r} is a built-in feature set and cannot be replaced")
    if name in _REGISTRY and not overwrite:
        raise ParameterError(f"feature {name!r} is already registered; pass overwrite=True to replace it")
    _REGISTRY[name] = fn


def register_file(name: str, path, *, file_fps: float | None = None, overwrite: bool = False) -> None:
    """Register an externally computed feature file under ``name``.

    The file (``.npz`` with ``values`` + ``fps``, or a csv with a ``time`` column / ``# fps=``
    line; see :mod:`headmotion.features.external`) is read at extraction time, checked against the
    audio's duration and linearly resampled to the requested ``fps`` and ``n_frames``.  ``extract(
    name, audio, path=other)`` reads another file with the same registration (one per recording).
    """
    from pathlib import Path

    from .external import file_feature, load_feature_file

    default = Path(path)
    load_feature_file(default, file_fps=file_fps)  # fail now on a bad file

    def _from_file(audio: Audio, *, fps: float, n_frames: int, path=None):
        return file_feature(default if path is None else path, fps=fps, n_frames=n_frames,
                            duration=audio.duration, file_fps=file_fps)

    _from_file.external = True  # type: ignore[attr-defined]
    register(name, _from_file, overwrite=overwrite)


def unregister(name: str) -> None:
    """Remove a registered (non built-in) feature set."""
    if name not in _REGISTRY:
        raise ParameterError(f"feature {name!r} is not registered")
    del _REGISTRY[name]


def _lookup(name: str):
    if name in _REGISTRY:
        return _REGISTRY[name], None
    if name in _BUILTIN:
        return _builtin(name), _BUILTIN[name][1]
    raise ParameterError(f"unknown feature set {name!r}; expected one of {', '.join(available())}")


def _check_params(name: str, fn, params: Mapping[str, Any]) -> None:
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        return
    if any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values()):
        return
    allowed = [p for p in sig.parameters if p not in ("audio", "fps", "n_frames")]
    bad = [k for k in params if k not in allowed]
    if bad:
        raise ParameterError(
            f"feature {name!r} has no parameter {', '.join(map(repr, bad))}; it accepts "
            f"{', '.join(allowed) or 'no parameters'}"
        )


def extract(name: str, audio: Audio, *, fps: float = DEFAULT_FPS, n_frames: int | None = None,
            analysis_rate: int | None = None, **params) -> FeatureTrack:
    """Compute one feature set.

    Parameters
    ----------
    name : str, one of :func:`available`
    audio : Audio
    fps : float, frames per second of the result
    n_frames : int, optional
        Exact length of the result (trim, or repeat the last frame); default
        :func:`headmotion.align.n_frames` ``(len(audio), audio.sample_rate, fps)``.
    analysis_rate : int, optional
        Rate the audio is resampled to first (default 16 kHz for the built-ins except ``wav``;
        registered extractors get the audio as it is).
    **params
        Passed to the extractor (e.g. ``voicing=True`` for ``f0e``, ``order=12`` for ``lsp``).

    Returns
    -------
    FeatureTrack [shape=(n_frames, D)]
    """
    from ..align import n_frames as count_frames
    from ..io.audio import resample
    from .frames import fit_length

    if not isinstance(audio, Audio):
        raise ParameterError(f"extract needs an Audio; got {type(audio).__name__}")
    fps = check_rate("fps", fps)
    if n_frames is None:
        n_frames = count_frames(len(audio), audio.sample_rate, fps)
    elif isinstance(n_frames, bool) or int(n_frames) != n_frames or n_frames < 0:
        raise ParameterError(f"n_frames must be a whole number >= 0; got {n_frames!r}")
    n_frames = int(n_frames)
    fn, default_rate = _lookup(name)
    _check_params(name, fn, params)
    rate = analysis_rate if analysis_rate is not None else default_rate
    if rate is not None and int(rate) != audio.sample_rate:
        if int(rate) <= 0:
            raise ParameterError(f"analysis_rate must be positive; got {rate}")
        audio = Audio(resample(audio.samples, audio.sample_rate, int(rate)), int(rate))
    out = fn(audio, fps=fps, n_frames=n_frames, **params)
    if isinstance(out, FeatureTrack):
        values, names = out.values, out.names
        if out.fps != fps:
            from ..align import resample_track

            values = resample_track(out, fps, n_frames).values
    elif isinstance(out, tuple) and len(out) == 2:
        values, names = out
    else:
        values = np.asarray(out)
        values = values[:, None] if values.ndim == 1 else values
        names = [f"{name}_{j}" for j in range(values.shape[1])]
    values = fit_length(np.asarray(values), n_frames)
    if not np.all(np.isfinite(values)):
        raise ParameterError(f"feature {name!r} produced NaN or inf values")  # an extractor bug
    return FeatureTrack(values.astype(np.float32, copy=False), fps, tuple(names))


@dataclass(frozen=True)
class FeatureConfig:
    """What a model needs to recompute its input features: name, frame rate, parameters.

    Parameters
    ----------
    name : str, a feature set name (:func:`available`)
    fps : float
    params : dict, JSON-serialisable keyword arguments for the extractor
    """

    name: str
    fps: float = DEFAULT_FPS
    params: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ParameterError(f"FeatureConfig.name must be a feature name; got {self.name!r}")
        fps = check_rate("FeatureConfig.fps", self.fps)
        params = dict(self.params or {})
        try:
            json.dumps(params)
        except TypeError as exc:
            raise ParameterError(f"FeatureConfig.params must be JSON-serialisable: {exc}") from None
        object.__setattr__(self, "fps", fps)
        object.__setattr__(self, "params", params)

    def __hash__(self) -> int:
        return hash((self.name, self.fps, json.dumps(dict(self.params), sort_keys=True)))

    def extract(self, audio: Audio, n_frames: int | None = None) -> FeatureTrack:
        """:func:`extract` with this configuration.  A built-in set's result for the same samples
        is read from the process's recent extractions (:mod:`.memo`): training and evaluation ask
        for one recording's features many times."""
        if self.name not in _BUILTIN or not isinstance(audio, Audio):  # (a registered set is never memoised)
            return extract(self.name, audio, fps=self.fps, n_frames=n_frames, **self.params)
        from . import memo

        k = memo.key(self, audio, n_frames)
        track = memo.get(k)
        if track is None:
            track = memo.put(k, extract(self.name, audio, fps=self.fps, n_frames=n_frames, **self.params))
        return track

    def to_dict(self) -> dict:
        return {"name": self.name, "fps": self.fps, "params": dict(self.params)}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "FeatureConfig":
        if not isinstance(d, Mapping) or "name" not in d:
            raise ParameterError(f"a feature configuration needs at least a 'name'; got {d!r}")
        extra = set(d) - {"name", "fps", "params"}
        if extra:
            raise ParameterError(f"unknown keys in feature configuration: {sorted(extra)}")
        return cls(name=d["name"], fps=d.get("fps", DEFAULT_FPS), params=d.get("params") or {})


def feature_config(features, fps: float) -> "FeatureConfig":
    """``features`` as a :class:`FeatureConfig`: one already, its dict (a model file's), or a set's
    name at ``fps``."""
    if isinstance(features, FeatureConfig):
        return features
    if isinstance(features, dict):
        return FeatureConfig.from_dict(features)
    return FeatureConfig(str(features), fps=float(fps))


__all__ = ["extract", "available", "register", "register_file", "unregister", "FeatureConfig", "feature_config",
           "Normalizer", "DEFAULT_FPS", "ANALYSIS_RATE"]
