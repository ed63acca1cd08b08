"""Adapt a motion-matching model to one speaker from a minute of their recordings
(``headmotion adapt``; docs/decisions/adapt.md).

A character rarely moves like the speakers a shipped model was built from, and a minute of one
speaker's motion is too little to be a library of its own: the takes repeat.  Adapting keeps the
base model's library and adds the speaker's recordings to it (:class:`~headmotion.systems.motion_match.MotionMatch`,
motion matching over recorded movements):

* the speaker's movements join the library, each with its prosody standardised as the base's
  (the input speech is standardised the same way), and are *preferred*: a frame of the base
  library pays ``base_cost`` more (:data:`BASE_COST`, chosen on speakers held out of the default's
  library; docs/decisions/adapt.md), so the base fills in where the speaker's minute has no
  movement for the speech;
* the range and posture follow the speaker: the mean pose is theirs, and the pose scales, the
  goal's regression and its range are fitted on their frames only;
* everything else — the matching settings, the prosody, the clip cleaning — is the base's.

Fitting is feature extraction over the speaker's material and one search-table build: seconds on
two cores.  The model file keeps which recordings are the speaker's and what it was adapted from
(``headmotion info``).
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..align import n_frames as _n_frames
from ..errors import ParameterError
from ..motion.angles import centred_degrees
from ..motion.control import AMOUNT_RANGE, mean_pose_of
from .base import Synthesizer
from .constraints import check_params, real, whole
from .motion_match import FPS, MotionMatch, clean_clips, clip_starts

#: the cost a frame of the base library pays over one of the speaker's (docs/decisions/adapt.md)
BASE_COST = 2.0
#: the least speech (seconds, by the voice activity detector) with motion an adaptation needs
MIN_SPEECH_S = 20.0
#: audio and motion of one recording may differ in length by this much (seconds) before the
#: pair is refused as mismatched
MAX_LENGTH_GAP_S = 1.0


def _corpus(corpus):
    from ..corpus import Corpus

    if isinstance(corpus, (str, os.PathLike)):
        path = Path(corpus)
        if not path.is_dir():
            raise ParameterError(f"{path}: is not a corpus folder; expected a folder made by `headmotion corpus "
                                 "import` or `headmotion corpus build` (recordings with speech and motion)")
        return Corpus.load(path)
    return corpus


def _base(base) -> MotionMatch:
    if isinstance(base, (str, os.PathLike)):
        from ..shipped import resolve_model_path
        from .base import load_model

        model = load_model(resolve_model_path(base))
    else:
        model = base
    if not isinstance(model, MotionMatch):
        raise ParameterError(f"base {base!r} is a {getattr(model, 'name', type(model).__name__)} model; "
                             "adapting needs a motion-match model (the shipped 'default' or 'stream', or one "
                             "trained with --system motion-match)")
    return model


def _speech_seconds(recording, n: int) -> float:
    from ..features.vad import speaking_mask

    return float(np.sum(speaking_mask(recording.audio, fps=FPS, n_frames=n))) / FPS


def _name(corpus) -> str:
    """How messages name the material: the path given, the corpus's folder, or "the corpus"."""
    if isinstance(corpus, (str, os.PathLike)):
        return str(corpus)
    root = getattr(corpus, "root", None)
    return str(root) if root else "the corpus"


def adapt(corpus, base="default", *, base_cost: float = BASE_COST, min_speech_s: float = MIN_SPEECH_S,
          repeat_cost: float | None = None, progress=None, name: str | None = None) -> MotionMatch:
    """A model adapted to the speaker of ``corpus`` (see the module docstring).

    Parameters
    ----------
    corpus : Corpus, str or Path
        The speaker's recordings with motion (mocap, tracked video or an imported dataset folder).
    base : str, Path or MotionMatch
        The model adapted: a shipped name (``"default"``, ``"stream"``), a motion-match model file
        or a loaded motion-match model.
    base_cost : float
        Cost of playing a frame of the base library rather than one of the speaker's (≥ 0; 0: no
        preference).
    min_speech_s : float
        The least speech with motion accepted (seconds).
    repeat_cost : float or None
        The adapted model's ``repeat_cost`` (None: the base's).
    progress : callable, optional
        ``progress(done, total, description)`` per recording.
    name : str, optional
        How error messages name the material (default: the path given or the corpus's folder).

    Returns
    -------
    MotionMatch
        Fitted; ``save`` it, synthesise with it, or serve it like any model.

    Raises :class:`~headmotion.errors.ParameterError` (nothing is written) when the corpus holds less
    than ``min_speech_s`` of speech, no speech, or a recording whose audio and motion differ in length.
    """
    if isinstance(base_cost, bool) or not isinstance(base_cost, (int, float)) or not np.isfinite(base_cost) \
            or base_cost < 0:
        raise ParameterError(f"base_cost must be a number >= 0; got {base_cost!r}")
    t0 = time.perf_counter()
    material = _corpus(corpus)
    where = name or _name(corpus)
    recs = list(material)
    if not recs:
        raise ParameterError(f"{where}: holds no recordings; adapting needs at least {min_speech_s:g} s of speech "
                             "with motion")
    model = _base(base)
    motions, feats, speech = [], [], 0.0
    for i, r in enumerate(recs):
        if r.motion is None:
            raise ParameterError(f"recording {r.id!r} has no motion; adapting needs speech with motion")
        a_s, m_s = len(r.audio.samples) / r.audio.sample_rate, r.motion.duration
        if abs(a_s - m_s) > MAX_LENGTH_GAP_S:
            raise ParameterError(f"recording {r.id!r}: its audio is {a_s:.1f} s but its motion {m_s:.1f} s; expected "
                                 f"a pair of the same take (lengths within {MAX_LENGTH_GAP_S:g} s)")
        n = _n_frames(len(r.audio.samples), r.audio.sample_rate, FPS)
        if n < int(model.hop) + 2:
            continue
        motions.append(centred_degrees(r.motion, n, FPS).astype(np.float32))
        feats.append(((model._prosody(r.audio, n) - model.feat_mean_) / model.feat_std_).astype(np.float32))
        speech += _speech_seconds(r, n)
        if progress is not None:
            progress(i + 1, len(recs), f"adapting: {r.id}")
    if speech < 1.0:
        raise ParameterError(f"{where}: no speech found in its recordings; adapting needs at least "
                             f"{min_speech_s:g} s of speech with motion")
    if speech < min_speech_s:
        raise ParameterError(f"{where}: {speech:.1f} s of speech with motion; adapting needs at least "
                             f"{min_speech_s:g} s")
    starts = [clip_starts(m) for m in motions]
    if model.lowpass:  # as the base's library was cleaned
        motions = [clean_clips(m, s, float(model.lowpass)) for m, s in zip(motions, starts)]
    base_starts = model.lib_starts_ if getattr(model, "lib_starts_", None) is not None else np.concatenate(
        [clip_starts(m) for m in np.split(model.lib_motion_, np.cumsum(model.lib_lengths_)[:-1])])
    base_own = np.zeros(len(model.lib_lengths_), bool)  # an adapted base's speaker becomes part of the base

    params = {**model.get_params(), "base_cost": float(base_cost)}
    if repeat_cost is not None:
        params["repeat_cost"] = float(repeat_cost)
    out = MotionMatch(**params)
    out.lib_motion_ = np.concatenate([model.lib_motion_, *motions]).astype(np.float32)
    out.lib_feats_ = np.concatenate([model.lib_feats_, *feats]).astype(np.float32)
    out.lib_lengths_ = np.r_[model.lib_lengths_, [len(m) for m in motions]].astype(np.int64)
    out.lib_starts_ = np.concatenate([base_starts, *starts]).astype(bool)
    out.lib_own_ = np.r_[base_own, np.ones(len(motions), bool)]
    out.feat_mean_, out.feat_std_ = model.feat_mean_, model.feat_std_
    out.mean_pose_ = mean_pose_of([r.motion.rotvec for r in recs])
    out.sample_rate_, out.fps_ = model.sample_rate_, FPS
    out.corpus_summary_ = material.summary() if hasattr(material, "summary") else None
    out.adapted_from_ = {"base": str(base) if isinstance(base, (str, os.PathLike)) else "a loaded model",
                         "base_corpus": getattr(model, "corpus_summary_", None),
                         "speech_seconds": round(speech, 1), "recordings": len(motions),
                         "base_cost": float(base_cost)}
    out.fit_warnings_ = []
    out._index()
    out.fit_seconds_ = time.perf_counter() - t0
    out.fitted_ = True
    return out




class Adapt(Synthesizer):
    """The registered system ``adapt``: :func:`adapt` as a system that trains on a corpus, so that
    ``headmotion evaluate --systems "adapt[base=default]"`` adapts on every fold's training
    recordings and ``headmotion train --system adapt`` writes the adapted model.

    Parameters
    ----------
    base : str, the model adapted (a shipped name or a motion-match model file)
    base_cost : float, cost of a base library frame over one of the speaker's
    min_speech_s : float, the least speech with motion accepted (seconds)
    repeat_cost : float or None, the adapted model's ``repeat_cost`` (None: the base's)
    amount : float, how much the head moves (:class:`~headmotion.systems.motion_match.MotionMatch`)
    seed : int, default synthesis seed
    """

    name: ClassVar[str] = "adapt"

    def __init__(self, *, base: str = "default", base_cost: float = BASE_COST, min_speech_s: float = MIN_SPEECH_S,
                 repeat_cost: float | None = None, amount: float = 1.0, seed: int = 0):
        self._store_params(locals())

    @property
    def capabilities(self) -> frozenset[str]:  # type: ignore[override]
        """The adapted model's (its base's)."""
        return self.model_.capabilities if self.is_fitted else frozenset()

    #: what each parameter may be (:mod:`.constraints`; ``base``: a shipped name or a file)
    _parameter_constraints: ClassVar[dict] = {"base_cost": [real(0)], "min_speech_s": [real(0)], "repeat_cost": [real(0), None],
                                              "amount": [real(*AMOUNT_RANGE)], "seed": [whole(0)]}

    def _validate_params(self) -> None:
        if not isinstance(self.base, (str, os.PathLike)):
            raise ParameterError(f"the 'base' parameter of adapt must be a shipped model name or a model file; "
                                 f"got {self.base!r}")
        check_params(self, self._parameter_constraints)

    def fit(self, corpus, *, progress=None) -> "Adapt":
        self._validate_params()
        self.model_ = adapt(corpus, self.base, base_cost=self.base_cost, min_speech_s=float(self.min_speech_s),
                            repeat_cost=self.repeat_cost, progress=progress)
        for k in ("mean_pose_", "sample_rate_", "fps_", "corpus_summary_", "fit_seconds_", "fit_warnings_"):
            setattr(self, k, getattr(self.model_, k))
        self.fitted_ = True
        return self

    def _model(self) -> MotionMatch:
        self.model_.set_params(amount=self.amount)
        self.model_._validate_params()
        return self.model_

    def _predict(self, audio, *, seed: int):
        return self._model()._predict(audio, seed=seed)

    def _stream(self, *, seed: int):
        return self._model()._stream(seed=seed)

    def _get_state(self):
        """The adapted model's state, with this system's parameters beside it (a file that loads
        as ``adapt``; ``headmotion adapt`` writes the motion-match model itself)."""
        config, arrays = self._model()._get_state()
        return {"adapt": self.get_params(), "model": config}, arrays

    def _set_state(self, config, arrays):
        for k, v in config["adapt"].items():
            setattr(self, k, v)
        inner = MotionMatch.__new__(MotionMatch)
        inner._set_state(config["model"], arrays)
        inner.mean_pose_ = np.asarray(arrays["mean_pose"], dtype=np.float64)
        inner.corpus_summary_ = config.get("corpus")
        inner.fitted_ = True
        self.model_ = inner
        self.sample_rate_, self.fps_, self.fit_warnings_ = inner.sample_rate_, inner.fps_, []

__all__ = ["adapt", "Adapt", "BASE_COST", "MIN_SPEECH_S"]
