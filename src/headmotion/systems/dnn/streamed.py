"""The DNN systems' training data streamed from disk, so that memory does not grow with the corpus
(``docs/decisions/bounded-training.md``).

Used instead of the in-memory path of :mod:`.data` when the system's ``train_path`` is
"streamed", or "auto" and the corpus is on disk with more than :data:`STREAM_MIN_SECONDS` of
training speech (:func:`uses_stream`); on the CPU or a GPU, for a corpus on disk or in memory.  One pass over the recordings (:func:`build`) reads each one's model-rate
features (from the corpus's feature cache), motion and speaking flags, writes them to a scratch
folder (one file per recording, removed after training) and accumulates:

* the feature and motion normalisers' means and SDs over the speaking training frames, exactly:
  per-recording means and sums of squared deviations merged by Chan, Golub & LeVeque's pairwise
  update (float64), equal to the concatenated statistics to rounding (:class:`Moments`);
* the mean pose (a running sum of pitch, yaw and roll over the training frames), exact.

The networks then read the recordings back a buffer at a time (:meth:`StreamedData.buffers`:
recordings in a seeded random order per epoch, up to :data:`BUFFER_FRAMES` frames, their frames
shuffled within the buffer; :mod:`.stream_training`).  The post-processing chain's tables (the
range limit's percentiles, the restoring gains, the speed map and its cross-fit) are fitted on a
seeded subsample of the training recordings of at most :data:`CALIBRATION_SECONDS`
(:func:`headmotion.systems.budget.budget_subset`): quantile tables, not sums.
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import ParameterError
from ...rotations import rotvec_to_pitch_yaw_roll
from ..budget import budget_subset, recording_seconds
from .data import Prepared, prepare

#: training speech (s) of a corpus on disk above which the networks train from streamed batches
STREAM_MIN_SECONDS = 3600.0
#: model-rate frames read into one shuffle buffer (25 min at 100 fps: ~60 MB of MFCC-39 windows)
BUFFER_FRAMES = 150_000
#: speech (s) of the seeded subsample the post-processing tables are fitted on
CALIBRATION_SECONDS = 7200.0


class Moments:
    """Per-dimension count, mean and sum of squared deviations of rows added in blocks (merged by
    the pairwise update of Chan, Golub & LeVeque 1979), in float64."""

    def __init__(self):
        self.n, self.mean, self.m2 = 0, None, None

    def add(self, x) -> None:
        x = np.asarray(x, dtype=np.float64)
        if not len(x):
            return
        nb, mb = len(x), x.mean(axis=0)
        m2b = ((x - mb) ** 2).sum(axis=0)
        if self.n == 0:
            self.n, self.mean, self.m2 = nb, mb, m2b
            return
        n = self.n + nb
        d = mb - self.mean
        self.mean = self.mean + d * (nb / n)
        self.m2 = self.m2 + m2b + d * d * (self.n * nb / n)
        self.n = n

    def normalizer(self, *, min_std: float = 1e-8):
        """The :class:`~headmotion.features.Normalizer` ``fit`` gives on the rows added."""
        from ...features import Normalizer

        if self.n == 0:
            raise ParameterError("no frames to fit a normaliser on")
        norm = Normalizer(min_std=min_std)
        std = np.sqrt(self.m2 / self.n)
        norm.mean_, norm.std_, norm.n_frames_ = self.mean, np.where(std < min_std, 1.0, std), int(self.n)
        return norm


@dataclass(frozen=True)
class Piece:
    """Frames ``[lo, hi)`` of stored recording ``key`` (a training recording, its validation tail
    ``#tail``, or a validation recording); ``index`` is the recording's place in the corpus."""

    key: int
    id: str
    lo: int
    hi: int
    index: int

    @property
    def frames(self) -> int:
        return self.hi - self.lo


class StreamedData:
    """The scratch folder of one training run: each recording's model-rate features, motion and
    speaking flags, read back one buffer at a time, normalised."""

    def __init__(self):
        self.folder = Path(tempfile.mkdtemp(prefix="headmotion-train-"))
        self.train: list[Piece] = []
        self.valid: list[Piece] = []
        self.feat_norm = self.mot_norm = None
        self.mean_pose = np.zeros(3)
        self.input_dim = 0
        self.n_speaking = 0
        self.fps_seen: set[float] = set()
        self._n = 0

    def close(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def put(self, p: Prepared) -> int:
        key, self._n = self._n, self._n + 1
        with open(self.folder / f"{key}.npz", "wb") as fh:
            np.savez(fh, feats=p.feats, motion=p.motion, speaking=p.speaking)
        return key

    def load(self, piece: Piece, *, all_speaking: bool = False, features: bool = True) -> Prepared:
        """The piece with ``x``, ``y`` (normalised, float32) and ``r = x`` set; ``all_speaking``:
        every frame counts when none speaks (validation pieces, as the in-memory path);
        ``features`` False: the motion and speaking flags only (``feats``, ``x``, ``r`` None), for
        the post-filter, which never reads the features."""
        keys = ("feats", "motion", "speaking") if features else ("motion", "speaking")
        with np.load(self.folder / f"{piece.key}.npz") as z:
            got = {k: z[k][piece.lo:piece.hi] for k in keys}
        p = Prepared(piece.id, got.get("feats"), got["motion"], got["speaking"])
        if all_speaking and not p.speaking.any():
            p.speaking = np.ones_like(p.speaking)
        p.x = np.asarray(self.feat_norm.transform(p.feats), dtype=np.float32) if features else None
        p.y = np.asarray(self.mot_norm.transform(p.motion), dtype=np.float32)
        p.r = p.x
        return p

    def buffers(self, pieces: list[Piece], order=None, *, limit: int = BUFFER_FRAMES, valid: bool = False,
                features: bool = True):
        """Lists of loaded pieces in ``order`` (indices into ``pieces``; default: as given), each
        list holding pieces until it reaches ``limit`` frames (``features`` as :meth:`load`)."""
        order = range(len(pieces)) if order is None else order
        buf, n = [], 0
        for k in order:
            p = self.load(pieces[int(k)], all_speaking=valid, features=features)
            buf.append(p)
            n += len(p.motion)
            if n >= limit:
                yield buf
                buf, n = [], 0
        if buf:
            yield buf


#: the values of the DNN systems' ``train_path`` parameter
TRAIN_PATHS = ("auto", "memory", "streamed")


def check_train_path(system) -> None:
    """Raise ParameterError unless ``system.train_path`` is one of :data:`TRAIN_PATHS` (and not
    "streamed" for a system with an embedding)."""
    path = system.train_path
    if path not in TRAIN_PATHS:
        raise ParameterError(f"the 'train_path' parameter of {system.name} must be one of {list(TRAIN_PATHS)}; "
                             f"got {path!r}")
    if path == "streamed" and system.uses_embedding:
        raise ParameterError(f"{system.name} trains in memory only (its CCA loss wants the whole training set "
                             f"at hand); use train_path='memory' or 'auto'")


def uses_stream(system, corpus, train_idx) -> bool:
    """Whether ``system`` trains from streamed batches: ``train_path`` "streamed", or "auto" on a
    corpus on disk with more than :data:`STREAM_MIN_SECONDS` of training speech (never the
    autoencoder systems).  The device does not decide it: each path runs on the CPU or a GPU."""
    check_train_path(system)
    if system.train_path != "auto":
        return system.train_path == "streamed"
    if system.uses_embedding or getattr(corpus, "root", None) is None:
        return False
    return sum(recording_seconds(corpus, i) for i in train_idx) > STREAM_MIN_SECONDS


def _add_training(data: StreamedData, p: Prepared, index: int, feats: Moments, motion: Moments,
                  pose: list) -> None:
    key = data.put(p)
    data.train.append(Piece(key, p.id, 0, len(p.feats), index))
    s = p.speaking
    feats.add(p.feats[s])
    motion.add(p.motion[s])
    if len(p.motion):
        pose[0] = pose[0] + rotvec_to_pitch_yaw_roll(p.motion).sum(axis=0)
        pose[1] += len(p.motion)
    data.n_speaking += int(s.sum())


def build(system, corpus, train_idx, valid_idx, config, progress=None) -> StreamedData:
    """One pass over the training (``train_idx``) and validation (``valid_idx``) recordings of
    ``corpus``: the scratch store, the normalisers and the mean pose (module docstring).  Without
    validation recordings each training recording's last ``valid_fraction`` is its validation tail,
    as in :func:`.data.training_data`."""
    fps = float(system.model_fps)
    data = StreamedData()
    try:
        feats, motion, pose = Moments(), Moments(), [np.zeros(3), 0]
        total = len(train_idx) + len(valid_idx)
        for n, i in enumerate(train_idx):
            rec = corpus[i]
            data.fps_seen.add(float(rec.motion.fps))
            p = prepare(rec, config, fps)
            data.input_dim = int(p.feats.shape[1])
            if not valid_idx:
                cut = int(round(len(p.feats) * (1 - float(system.valid_fraction))))
                tail = p.part(cut, None, "#tail")
                p = p.part(0, cut, "")
                _add_training(data, p, i, feats, motion, pose)
                if len(tail.feats):
                    data.valid.append(Piece(data.put(tail), tail.id, 0, len(tail.feats), i))
            else:
                _add_training(data, p, i, feats, motion, pose)
            if progress is not None:
                progress((n + 1) / max(total, 1), f"reading {rec.id}")
        for n, i in enumerate(valid_idx):
            p = prepare(corpus[i], config, fps)
            if len(p.feats):
                data.valid.append(Piece(data.put(p), p.id, 0, len(p.feats), i))
            if progress is not None:
                progress((len(train_idx) + n + 1) / max(total, 1), f"reading {p.id}")
        need = max(2 * int(system.context) + 1, 50)
        if data.n_speaking < need:
            raise ParameterError(
                f"only {data.n_speaking} speaking frames in the training recordings of {system.name}; need at "
                f"least {need} (is the speaking annotation or the audio empty?)")
        if not data.valid:
            raise ParameterError(f"{system.name}: no validation frames (valid_fraction {system.valid_fraction})")
        data.feat_norm, data.mot_norm = feats.normalizer(), motion.normalizer()
        data.mean_pose = pose[0] / max(pose[1], 1)
        return data
    except BaseException:
        data.close()
        raise


def calibration_pieces(system, data: StreamedData, corpus) -> tuple[list[Prepared], list[Prepared]]:
    """The training and validation pieces the post-processing tables are fitted on: a seeded
    subsample of the training recordings of at most :data:`CALIBRATION_SECONDS` (with their
    validation tails), and of the validation recordings at most a quarter of that."""
    seed = int(system.random_state)
    train_idx = [p.index for p in data.train]
    keep = set(budget_subset(corpus, CALIBRATION_SECONDS, seed=seed, indices=train_idx))
    tails = any(p.id.endswith("#tail") for p in data.valid)
    if tails:
        vkeep = keep
    else:
        vkeep = set(budget_subset(corpus, CALIBRATION_SECONDS / 4, seed=seed, indices=[p.index for p in data.valid]))
    train = [data.load(p) for p in data.train if p.index in keep]
    valid = [data.load(p, all_speaking=True) for p in data.valid if p.index in vkeep]
    return train, valid


__all__ = ["STREAM_MIN_SECONDS", "BUFFER_FRAMES", "CALIBRATION_SECONDS", "TRAIN_PATHS", "Moments", "Piece",
           "StreamedData", "check_train_path", "uses_stream", "build", "calibration_pieces"]
