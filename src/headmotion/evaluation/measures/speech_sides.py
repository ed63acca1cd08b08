"""The speech side of the cross-speaker coupling: which reading of the voice the projections see.

:class:`~.cross_coupling.CrossSpeakerCCA` projects speech features and head motion on directions
fitted on recorded heads.  Which features stand for the speech decides what "tied to speech" means,
and a model that reads the voice one way should not be scored only by that same reading.  Three
speech sides, each fitted on the recorded heads with its own features:

* ``praat`` — F0 and energy read by Praat over the whole file (``f0e``: ``logf0, energy`` and their
  deltas and delta-deltas, 6 columns; :func:`headmotion.features.prosody.f0e`).  The measure as
  it has always been: same features, same numbers;
* ``own`` — the project's own frame-by-frame reading (``f0e-live`` with its YIN reader,
  ``voicing=True`` and ``voicing_threshold=0.45``, as docs/decisions/follow-any-voice.md chose it;
  its 6 F0 and energy columns, the same names as ``praat``'s): the pitch a YIN tracker hears,
  without Praat;
* ``energy`` — energy and its deltas only (``energy, d_energy, dd_energy`` of ``f0e``: the frame log
  energy, smoothed over 0.1 s): no pitch at all, so a model is not scored on how a pitch tracker
  reads the voice.

    >>> track = side_features(audio, "own", fps=25.0)
    >>> sides = parse_sides("all")            # ("praat", "own", "energy")
"""

from __future__ import annotations

from typing import Iterable, Mapping

from ...errors import ParameterError
from ...types import Audio, FeatureTrack

#: the speech sides, the measure's default (today's) first
SPEECH_SIDES = ("praat", "own", "energy")
#: the side the coupling measure has always used
DEFAULT_SIDE = "praat"
#: what each side reads, for reports
SIDE_DESCRIPTIONS = {
    "praat": "Praat F0 + energy over the whole file (f0e, 6 columns)",
    "own": "the project's frame-by-frame F0 + energy (f0e-live, YIN, voicing threshold 0.45, 6 columns)",
    "energy": "energy and its deltas only, no pitch (3 columns)",
}
#: the F0 + energy columns of ``f0e`` and ``f0e-live``
F0E_COLUMNS = ("logf0", "energy", "d_logf0", "d_energy", "dd_logf0", "dd_energy")
#: the columns of the ``energy`` side
ENERGY_COLUMNS = ("energy", "d_energy", "dd_energy")
#: the ``own`` side's reading: YIN frame by frame at the voicing threshold follow-any-voice.md chose
OWN_PARAMS = {"reader": "yin", "voicing": True, "voicing_threshold": 0.45}


def parse_sides(sides: str | Iterable[str] | None) -> tuple[str, ...]:
    """The speech sides named: ``"all"`` (or None) for every one, else a comma-separated text or a
    sequence of names from :data:`SPEECH_SIDES` (in the order given, once each).

    Raises
    ------
    ParameterError — an unknown side or none at all
    """
    if sides is None:
        return SPEECH_SIDES
    names = [s.strip() for s in sides.split(",")] if isinstance(sides, str) else [str(s).strip() for s in sides]
    names = [s for s in names if s]
    if names == ["all"]:
        return SPEECH_SIDES
    bad = [s for s in names if s not in SPEECH_SIDES]
    if bad or not names:
        raise ParameterError(f"speech sides are {', '.join(SPEECH_SIDES)} or 'all'; got {sides!r}")
    return tuple(dict.fromkeys(names))


def side_features(audio: Audio, side: str, *, fps: float, n_frames: int | None = None) -> FeatureTrack:
    """The speech features of one side for ``audio`` (module docstring).

    Parameters
    ----------
    audio : Audio
    side : one of :data:`SPEECH_SIDES`
    fps : float, frames per second of the features
    n_frames : int, optional — exact length (:func:`headmotion.features.extract`'s default otherwise)

    Returns
    -------
    FeatureTrack [shape=(n_frames, 6 | 3)]
    """
    return sides_features(audio, (side,), fps=fps, n_frames=n_frames)[side]


def sides_features(audio: Audio, sides: Iterable[str], *, fps: float,
                   n_frames: int | None = None) -> Mapping[str, FeatureTrack]:
    """:func:`side_features` of several sides, reading each extractor once (``praat`` and
    ``energy`` share one ``f0e`` extraction)."""
    from ...features import extract

    sides = parse_sides(tuple(sides))
    out: dict[str, FeatureTrack] = {}
    if "praat" in sides or "energy" in sides:
        f0e = extract("f0e", audio, fps=fps, n_frames=n_frames)
        if "praat" in sides:
            out["praat"] = f0e
        if "energy" in sides:
            out["energy"] = f0e.select(ENERGY_COLUMNS)
    if "own" in sides:
        out["own"] = extract("f0e-live", audio, fps=fps, n_frames=n_frames, **OWN_PARAMS).select(F0E_COLUMNS)
    return {s: out[s] for s in sides}


__all__ = ["SPEECH_SIDES", "DEFAULT_SIDE", "SIDE_DESCRIPTIONS", "F0E_COLUMNS", "ENERGY_COLUMNS", "OWN_PARAMS",
           "parse_sides", "side_features", "sides_features"]
