"""The server's one door into synthesis: every call the service makes into the library goes
through this module (models by name, offline synthesis, streams), so that the routes never touch
a system's methods directly.

It is written on the systems' contract (:mod:`headmotion.systems.base`: ``load_model``,
``predict(audio, seed=, gain=, offset=)``, ``stream(seed=, gain=, offset=)``) and the controls of
``headmotion synth`` (:mod:`headmotion.motion.control`).  When the library's single synthesis
module (``headmotion.synthesis``: ``load_model``, ``synthesize``, ``open_stream``, ``Controls``)
is present, the bodies of :func:`load`, :func:`synthesize` and :func:`open_stream` become one
call each into it; the signatures here stay.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ModelFileError, ParameterError
from ..types import Audio, Motion

DATA = Path(__file__).resolve().parents[1] / "data"
#: the models shipped in the package, by the names the API knows them by
SHIPPED = {"default": DATA / "default_model.hmz", "stream": DATA / "default_stream_model.hmz"}
DEFAULT_OFFLINE, DEFAULT_STREAM = "default", "stream"


@dataclass(frozen=True)
class Controls:
    """What a request may change about the motion: gain about the model's mean pose and offset
    (radians) per axis (pitch, yaw, roll), a still head, the output frame rate."""

    gain: tuple[float, float, float] = (1.0, 1.0, 1.0)
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    still: bool = False
    fps: float | None = None

    @classmethod
    def parse(cls, *, gain=None, offset_deg=None, gain_pyr=(None, None, None),
              offset_pyr_deg=(None, None, None), still: bool = False, fps=None) -> "Controls":
        """Controls from request values: ``gain`` / ``offset_deg`` a number, a (p, y, r) triple or
        the CLI's text ``"1.2"`` / ``"1,0.5,1"``; the per-axis values override them on their axis.
        Offsets are given in degrees (as on the command line) and kept in radians."""
        from ..motion.control import per_axis

        g = per_axis(_triple(gain, "gain", 1.0), *gain_pyr, what="gain")
        o_deg = per_axis(_triple(offset_deg, "offset", 0.0), *offset_pyr_deg, what="offset")
        if fps is not None:
            fps = float(fps)
            if not (np.isfinite(fps) and 1.0 <= fps <= 1000.0):
                raise ParameterError(f"fps must be between 1 and 1000 frames per second; got {fps}")
        return cls(tuple(float(v) for v in g), tuple(float(v) for v in np.radians(o_deg)), bool(still), fps)


def _triple(value, what: str, default: float):
    if value is None:
        return default
    if isinstance(value, str):
        try:
            vals = [float(v) for v in value.split(",")]
        except ValueError:
            raise ParameterError(f"{what} must be a number or three comma-separated numbers "
                                 f"(pitch,yaw,roll); got {value!r}") from None
        if len(vals) not in (1, 3):
            raise ParameterError(f"{what} must be one number or three (pitch,yaw,roll); got {value!r}")
        return vals[0] if len(vals) == 1 else vals
    return value


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
    from ..systems.base import load_model

    return load_model(path)


def card(name: str, model, path: Path) -> dict:
    """What ``GET /v1/models`` says about a model: rates, latency, lookahead, capabilities and the
    first line of its model card (``NAME.md`` beside the file) when there is one."""
    caps = sorted(model.capabilities)
    latency = float(model.stream(seed=0).latency_ms) if model.can_stream else None
    md = path.with_suffix(".md")
    summary = None
    if md.exists():
        lines = [ln.strip() for ln in md.read_text(encoding="utf-8").splitlines() if ln.strip()]
        summary = next((ln for ln in lines if not ln.startswith("#")), None)
    return {"name": name, "system": model.name, "sample_rate": int(model.sample_rate),
            "frame_rate": float(model.frame_rate), "capabilities": caps, "streams": bool(model.can_stream),
            "latency_ms": latency, "lookahead_ms": latency, "seeded": "seed" in model.get_params(),
            "card": summary}


def synthesize(model, audio: Audio, *, seed: int = 0, samples: int = 1,
               controls: Controls = Controls()) -> list[Motion]:
    """``samples`` motions for ``audio`` (sample k with seed ``seed + k``), the controls applied
    as ``headmotion synth`` applies them (gain/offset about the mean pose, or a still head plus
    the offset; then the frame rate)."""
    from ..motion.control import still as still_motion

    if not 1 <= int(samples) <= 16:
        raise ParameterError(f"samples must be between 1 and 16; got {samples}")
    out = []
    for k in range(int(samples)):
        if controls.still:
            m = still_motion(model.predict(audio, seed=seed + k), controls.offset)
        else:
            m = model.predict(audio, seed=seed + k, gain=controls.gain, offset=controls.offset)
        out.append(m if controls.fps is None else m.resample(controls.fps))
    return out


class _StillStream:
    """A stream whose frames are the rest pose plus the offset (``still``), as many and as final
    as the model's."""

    def __init__(self, inner, offset):
        self.inner, self.offset, self.latency_ms = inner, offset, inner.latency_ms

    def push(self, samples) -> Motion:
        from ..motion.control import still

        return still(self.inner.push(samples), self.offset)

    def flush(self) -> Motion:
        from ..motion.control import still

        return still(self.inner.flush(), self.offset)


def open_stream(model, *, seed: int = 0, controls: Controls = Controls()):
    """A fresh stream of ``model``: ``push(float32 samples at model.sample_rate) -> Motion`` of
    the frames now final, ``flush() -> Motion`` of the rest; ``latency_ms`` its lookahead.
    Frames come at the model's rate (``controls.fps`` applies to offline synthesis only)."""
    if not model.can_stream:
        raise ParameterError(f"model {model.name!r} cannot stream; choose a model whose card lists "
                             f"'causal' or 'streaming'")
    if controls.fps is not None:
        raise ParameterError("fps is an offline control; a stream sends frames at the model's rate")
    if controls.still:
        return _StillStream(model.stream(seed=seed), controls.offset)
    return model.stream(seed=seed, gain=controls.gain, offset=controls.offset)


def check_loaded(files: dict[str, Path]) -> None:
    """Refuse to start without a model to serve."""
    if not files:
        raise ModelFileError("no model to serve: the shipped models are missing and no --models folder was given")


__all__ = ["Controls", "SHIPPED", "DEFAULT_OFFLINE", "DEFAULT_STREAM", "model_files", "load", "card",
           "synthesize", "open_stream", "check_loaded"]
