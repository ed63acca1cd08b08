"""Training data of the DNN systems (paper §4.1–4.2): features and motion at the model rate, the
train / valid split, the validation tails, and the normalisers."""

from __future__ import annotations

import numpy as np

from ...align import fit_length, n_frames
from ...errors import ParameterError


class Prepared:
    """One recording (or part of one) at the model frame rate: features ``feats``, rotation
    vectors ``motion`` and speaking flags; training adds the normalised ``x``, ``y`` and the
    regressor input ``r`` (and ``z``, the embedding, for the autoencoder systems)."""

    def __init__(self, rid: str, feats: np.ndarray, motion: np.ndarray, speaking: np.ndarray):
        self.id, self.feats, self.motion, self.speaking = rid, feats, motion, speaking

    def part(self, a: int, b: int | None, suffix: str) -> "Prepared":
        return Prepared(self.id + suffix, self.feats[a:b], self.motion[a:b], self.speaking[a:b])


def extract(audio, T: int, config) -> np.ndarray:
    """Model-rate features ``(T, D)`` float32 of ``audio``."""
    return np.asarray(config.extract(audio, n_frames=T).values, dtype=np.float32)


def prepare(rec, config, fps: float) -> Prepared:
    """A recording's features, motion and speaking flags at the model rate ``fps``."""
    from ...feature_cache import features_for  # the corpus's feature cache when it has one

    T = n_frames(len(rec.audio.samples), rec.audio.sample_rate, fps)
    feats = np.asarray(features_for(rec, config, T).values, dtype=np.float32)
    mot = rec.motion.resample(fps)
    motion = fit_length(np.asarray(mot.rotvec, dtype=np.float64), T)
    if rec.speaking is not None:
        src = np.asarray(rec.speaking, dtype=bool)
        # the motion frame holding each model frame's time t / fps (the align convention)
        idx = np.minimum(np.floor(np.arange(T) * rec.motion.fps / fps + 1e-9).astype(np.int64), len(src) - 1)
        speaking = src[idx] if len(src) else np.zeros(T, bool)
    else:
        from ...features.vad import speaking_mask

        speaking = np.asarray(speaking_mask(rec.audio, fps=fps, n_frames=T), dtype=bool)
    return Prepared(rec.id, feats, motion, speaking)


def split(corpus, *, random_state: int, holdout_test: bool) -> dict[str, str]:
    """Recording id → "train" / "valid" / "test" (:func:`headmotion.corpus.paper_split`); without a
    manifest split, or with ``holdout_test`` False, the "test" recordings are trained on."""
    from ...corpus import paper_split

    explicit = all(e.split for e in corpus.entries)
    out = paper_split(corpus, seed=int(random_state))
    if not explicit or not holdout_test:
        out = {k: ("train" if v == "test" else v) for k, v in out.items()}
    return out


def training_data(system, train_recs, valid_recs, config) -> tuple[list[Prepared], list[Prepared]]:
    """Features and motion at the model rate; validation recordings, or (when there are none) the
    tail of every training recording (``valid_fraction``); checks there is enough speech."""
    fps = float(system.model_fps)
    train = [prepare(r, config, fps) for r in train_recs]
    valid = [prepare(r, config, fps) for r in valid_recs]
    if not valid:
        tr, va = [], []
        for p in train:
            cut = int(round(len(p.feats) * (1 - float(system.valid_fraction))))
            tr.append(p.part(0, cut, ""))
            va.append(p.part(cut, None, "#tail"))
        train, valid = tr, va
    n_speak = sum(int(p.speaking.sum()) for p in train)
    need = max(2 * int(system.context) + 1, 50)
    if n_speak < need:
        raise ParameterError(
            f"only {n_speak} speaking frames in the training recordings of {system.name}; need at least "
            f"{need} (is the speaking annotation or the audio empty?)")
    for p in valid:  # validation frames: speaking ones, or all when none speaks
        if not p.speaking.any():
            p.speaking = np.ones_like(p.speaking)
    valid = [p for p in valid if len(p.feats)]
    if not valid:
        raise ParameterError(f"{system.name}: no validation frames (valid_fraction {system.valid_fraction})")
    return train, valid


def normalise(train, valid):
    """Feature and motion normalisers fitted on the speaking training frames; sets ``p.x``, ``p.y``."""
    from ...features import Normalizer

    feat_norm = Normalizer().fit([p.feats[p.speaking] for p in train])
    mot_norm = Normalizer().fit([p.motion[p.speaking] for p in train])
    for p in train + valid:
        p.x = np.asarray(feat_norm.transform(p.feats), dtype=np.float32)
        p.y = np.asarray(mot_norm.transform(p.motion), dtype=np.float32)
    return feat_norm, mot_norm


def held_out_views(train: list[Prepared], valid: list[Prepared]) -> list[tuple[np.ndarray, np.ndarray, int]]:
    """``(network input, normalised motion, first validation frame)`` per validation piece: a
    validation tail joined back to the training part it was cut from (so the filters and the
    network's context run over the whole recording, and only the tail is counted), or a whole
    validation recording (counted from frame 0)."""
    parts = {p.id: p for p in train}
    out = []
    for v in valid:
        head = parts.get(v.id.removesuffix("#tail")) if v.id.endswith("#tail") else None
        if head is None:
            out.append((v.r, v.y, 0))
        else:
            out.append((np.concatenate([head.r, v.r]), np.concatenate([head.y, v.y]), len(head.r)))
    return out


__all__ = ["Prepared", "extract", "prepare", "split", "training_data", "normalise", "held_out_views"]
