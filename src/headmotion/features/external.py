"""Externally computed feature tracks (thesis §5.7.1: EMA from speech inversion).

The thesis's best features were articulator (EMA) trajectories predicted by an HMM speech-inversion
system that is not available to us; any such track computed by another tool can be plugged in with
:func:`headmotion.features.register_file` and is read here, then linearly resampled to the requested
frame rate and length (:func:`headmotion.align.resample_track`).

Accepted files:

* ``.npz`` with ``values`` ``(T, D)``, ``fps`` (scalar) and optionally ``names`` ``(D,)``;
* ``.csv`` / ``.tsv`` / ``.txt`` with a header row of column names and either a ``time`` column
  (seconds, increasing; the rows are interpolated onto frame times ``k / fps`` with ``fps`` from
  the median time step) or an ``fps`` in a comment line ``# fps=200`` (row ``k`` is then frame
  ``k``, at time ``k / fps``: the frame-time convention of :mod:`headmotion.align`);
* ``.npy`` ``(T, D)`` when ``file_fps`` is given.

No library reads these ad-hoc layouts; numpy does the parsing.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..align import DEFAULT_TOLERANCE_S, resample_track
from ..errors import FormatError, LengthMismatchError, ParameterError
from ..io._limits import check_file
from ..types import FeatureTrack


def _read_csv(path: Path, file_fps: float | None):
    text = path.read_text(encoding="utf-8-sig")
    lines = [ln for ln in text.splitlines() if ln.strip()]
    fps = file_fps
    body = []
    header = None
    for i, ln in enumerate(lines, 1):
        s = ln.strip()
        if s.startswith("#"):
            key = s.lstrip("#").strip().replace(":", "=").replace(" ", "")
            if key.lower().startswith("fps="):
                try:
                    fps = float(key.split("=", 1)[1])
                except ValueError:
                    raise FormatError(f"cannot read the frame rate from {s!r}", path=path, line=i) from None
            continue
        delim = "\t" if "\t" in s else ("," if "," in s else None)
        cells = [c.strip() for c in (s.split(delim) if delim else s.split())]
        if header is None:
            try:
                [float(c) for c in cells]
                header = [f"f{j}" for j in range(len(cells))]
            except ValueError:
                header = cells
                continue
        if len(cells) != len(header):
            raise FormatError(f"expected {len(header)} values, found {len(cells)}", path=path, line=i)
        try:
            body.append([float(c) for c in cells])
        except ValueError:
            raise FormatError(f"non-numeric value in {s!r}", path=path, line=i) from None
    if header is None or not body:
        raise FormatError("no data rows; expected a header and numeric rows", path=path)
    values = np.asarray(body, dtype=np.float64)
    names = list(header)
    lower = [n.lower() for n in names]
    if "time" in lower:
        j = lower.index("time")
        t = values[:, j]
        values = np.delete(values, j, axis=1)
        del names[j]
        if len(t) < 2 or np.any(np.diff(t) <= 0):
            raise FormatError("the time column must increase", path=path)
        if fps is None:
            fps = 1.0 / float(np.median(np.diff(t)))
        # the time column says where each row is: interpolate onto frame times k / fps
        n = max(1, int(np.floor(t[-1] * fps + 1e-6)) + 1)
        times = np.arange(n) / fps
        values = np.stack([np.interp(times, t, values[:, k]) for k in range(values.shape[1])], 1)
    if fps is None:
        raise FormatError("no frame rate: add a 'time' column or a first line '# fps=100'", path=path)
    return values, float(fps), names


def load_feature_file(path, *, file_fps: float | None = None) -> FeatureTrack:
    """Read an external feature file at its own rate.

    Parameters
    ----------
    path : str or Path (.npz, .csv, .tsv, .txt, .npy)
    file_fps : float, optional, frame rate when the file does not state one

    Returns
    -------
    FeatureTrack
    """
    path = check_file(path, expected="a feature file (.npz, .csv, .tsv, .txt, .npy)")
    ext = path.suffix.lower()
    if ext == ".npz":
        try:
            with np.load(path, allow_pickle=False) as z:
                if "values" not in z:
                    raise FormatError(f"npz lacks 'values' (has {sorted(z.files)})", path=path)
                values = np.asarray(z["values"], dtype=np.float64)
                fps = float(z["fps"]) if "fps" in z else file_fps
                names = [str(n) for n in z["names"]] if "names" in z else None
        except (OSError, ValueError) as exc:
            raise FormatError(f"not a readable npz file ({exc})", path=path) from None
        if fps is None:
            raise FormatError("npz lacks 'fps'; pass file_fps=", path=path)
    elif ext == ".npy":
        values = np.load(path, allow_pickle=False).astype(np.float64)
        if file_fps is None:
            raise FormatError(".npy files carry no frame rate; pass file_fps=", path=path)
        fps, names = float(file_fps), None
    elif ext in (".csv", ".tsv", ".txt"):
        values, fps, names = _read_csv(path, file_fps)
    else:
        raise FormatError(f"unknown feature file type {ext!r}; expected .npz, .csv, .tsv, .txt, .npy",
                          path=path)
    if values.ndim == 1:
        values = values[:, None]
    if values.ndim != 2 or len(values) == 0:
        raise FormatError(f"expected a (T, D) array with T > 0; got shape {values.shape}", path=path)
    if not np.all(np.isfinite(values)):
        raise FormatError("values contain NaN or inf", path=path)
    if names is None or len(names) != values.shape[1]:
        names = [f"{path.stem}_{j}" for j in range(values.shape[1])]
    return FeatureTrack(values, fps, tuple(names))


def file_feature(path, *, fps: float, n_frames: int, duration: float | None = None,
                 file_fps: float | None = None, tolerance_s: float = DEFAULT_TOLERANCE_S) -> FeatureTrack:
    """An external feature file resampled to ``fps`` and exactly ``n_frames`` frames.

    ``duration`` (seconds, e.g. of the audio the track belongs to) is checked against the file's:
    they must agree within one frame of the coarser rate plus ``tolerance_s``.
    """
    track = load_feature_file(path, file_fps=file_fps)
    if fps <= 0:
        raise ParameterError(f"fps must be positive; got {fps}")
    if duration is not None:
        tol = 1.0 / min(fps, track.fps) + tolerance_s
        if abs(track.duration - duration) > tol:
            raise LengthMismatchError(
                f"{path}: feature file lasts {track.duration:.3f} s ({len(track)} frames at "
                f"{track.fps:g}/s) but the audio lasts {duration:.3f} s; tolerance {tol:.3f} s"
            )
    return resample_track(track, fps, n_frames)


__all__ = ["load_feature_file", "file_feature"]
