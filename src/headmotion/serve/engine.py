"""The server's one door into synthesis: every call the service makes into the library goes
through this module, and this module calls the library's one synthesis path
(:mod:`headmotion.synthesis`: ``load_model``, ``synthesize``, ``open_stream``, ``list_models``),
so a request gets exactly the motion ``headmotion synth`` / ``headmotion stream`` give.

The request-level :class:`Controls` (offsets in degrees on the wire, radians kept) map one-to-one
onto :class:`headmotion.synthesis.Controls`.
"""

from __future__ import annotations

from pathlib import Path


from .. import synthesis
from ..errors import ModelFileError, ParameterError
from ..shipped import SHIPPED_FILES, shipped_path
from ..types import Audio, Motion

#: the models shipped in the package, by the names the API knows them by (:mod:`headmotion.shipped`)
SHIPPED = {name: shipped_path(name) for name in SHIPPED_FILES}
DEFAULT_OFFLINE, DEFAULT_STREAM = "default", "stream"
#: the controls and their ranges are the library's (:class:`headmotion.synthesis.Controls`, parsed
#: once per request with offsets in degrees, as on the command line); the service's own range:
#: samples per offline request
Controls = synthesis.Controls
FPS_RANGE = synthesis.FPS_RANGE
MAX_SAMPLES = 16
check_seed = synthesis.check_seed


def model_files(models_dir: Path | None = None) -> dict[str, Path]:
    """Name → file of every model the server offers: the shipped ``default`` and ``stream``,
    and each ``NAME.hmz`` in ``models_dir`` (a file there may replace a shipped name)."""
    files = {k: v for k, v in SHIPPED.items() if v.exists()}
    if models_dir is not None:
        d = Path(models_dir)
        if not d.is_dir():
            raise ParameterError(f"--models {d}: not a folder of .hmz model files")
        found = sorted(d.glob("*.hmz"))
        if not found:
            raise ParameterError(f"--models {d}: holds no .hmz model file")
        files.update({p.stem: p for p in found})
    return files


def load(path: Path):
    """A loaded model (read once; shared by every request of this worker)."""
    return synthesis.load_model(path)


def card(name: str, model, path: Path | None) -> dict:
    """What ``GET /v1/models`` says about a model: rates, latency, lookahead, capabilities and the
    first line of its model card (``NAME.md`` beside the file) when there is one."""
    caps = sorted(model.capabilities)
    latency = float(model.stream(seed=0).latency_ms) if model.can_stream else None
    md = None if path is None else Path(path).with_suffix(".md")
    summary = None
    if md is not None and md.exists():
        lines = [ln.strip() for ln in md.read_text(encoding="utf-8").splitlines() if ln.strip()]
        summary = next((ln for ln in lines if not ln.startswith("#")), None)
    return {"name": name, "system": model.name, "sample_rate": int(model.sample_rate),
            "frame_rate": float(model.frame_rate), "capabilities": caps, "streams": bool(model.can_stream),
            "latency_ms": latency, "lookahead_ms": latency, "seeded": "seed" in model.get_params(),
            "card": summary}


def synthesize(model, audio: Audio, *, seed: int | None = None, samples: int = 1,
               controls: Controls = Controls()) -> list[Motion]:
    """``samples`` motions for ``audio`` (sample k with seed ``seed + k``) from
    :func:`headmotion.synthesis.synthesize`, the controls applied as ``headmotion synth`` applies them."""
    if not 1 <= int(samples) <= MAX_SAMPLES:
        raise ParameterError(f"samples must be between 1 and {MAX_SAMPLES}; got {samples}")
    return synthesis.synthesize(audio, model, seed=seed, samples=int(samples), controls=controls)


def open_stream(model, *, seed: int | None = None, controls: Controls = Controls(), sample_rate: int | None = None,
                resample: str = "exact", heard_rate: int | None = None):
    """A fresh stream of ``model`` (:func:`headmotion.synthesis.open_stream`): ``push(float32
    samples at sample_rate) -> Motion`` of the frames now final (resampled on the stream,
    ``resample``), ``hear(samples at heard_rate)``, ``flush() -> Motion`` of the rest;
    ``latency_ms`` its lookahead.  Frames come at the model's rate (``controls.fps`` applies to
    offline synthesis only)."""
    if not model.can_stream:
        raise ParameterError(f"model {model.name!r} cannot stream; choose a model whose card lists "
                             f"'causal' or 'streaming'")
    if controls.fps is not None:
        raise ParameterError("fps is an offline control; a stream sends frames at the model's rate")
    return synthesis.open_stream(model, seed=seed, controls=controls, sample_rate=sample_rate, resample=resample,
                                 heard_rate=heard_rate)


def check_loaded(files: dict[str, Path]) -> None:
    """Refuse to start without a model to serve."""
    if not files:
        raise ModelFileError("no model to serve: the shipped models are missing and no --models folder was given")


__all__ = ["Controls", "FPS_RANGE", "MAX_SAMPLES", "check_seed", "SHIPPED", "DEFAULT_OFFLINE", "DEFAULT_STREAM", "model_files", "load", "card",
           "synthesize", "open_stream", "check_loaded"]
