""":meth:`DnnSystem.fit <headmotion.systems.dnn.system.DnnSystem.fit>` from streamed batches: the
training data of :mod:`.streamed`, the networks of :mod:`.stream_training`, then the
post-processing tables of :mod:`.calibration` on the seeded calibration subsample.  Stages
reported to ``progress``: reading the recordings, the regressor, the post-filter, the tables."""

from __future__ import annotations

import time

from ...devices import resolve_device
from ...errors import ParameterError
from ...models.train_speed import Speed
from ...motion.post.range_limit import range_from_training
from ..budget import budget_subset
from . import calibration, stream_training, streamed
from .training import clean_json, torch_context


class _Report:
    """``progress(stage + fraction, n_stages, description)`` per stage, when there is a callback."""

    def __init__(self, system, progress, n_stages: int):
        self.name, self.progress, self.n = system.name, progress, n_stages

    def stage(self, k: int):
        def tick(fraction: float, description: str) -> None:
            if self.progress is not None:
                self.progress(k + min(max(fraction, 0.0), 1.0), self.n, f"{self.name}: {description}")
        return tick


def fit_streamed(system, corpus, split: dict, config, progress=None, t0: float | None = None):
    """Train ``system`` (no embedding) on ``corpus`` with the recordings read from disk as needed
    (``split``: recording id → train / valid / test, as :func:`.data.split`).  Returns ``system``."""
    t0 = time.perf_counter() if t0 is None else t0
    ids = list(corpus.ids)
    train_idx = [i for i, rid in enumerate(ids) if split[rid] == "train"]
    valid_idx = [i for i, rid in enumerate(ids) if split[rid] == "valid"]
    if not train_idx:
        raise ParameterError(f"no training recordings in the corpus (splits: {split})")
    device = resolve_device(system.device)
    n_stages = 3 + (1 if system.postfilter else 0)
    report = _Report(system, progress, n_stages)
    history: dict = {"streamed": True, "device": device}
    speed = Speed.of(system, device)
    if speed != Speed(device):
        history["speed"] = speed.describe()
    with streamed.build(system, corpus, train_idx, valid_idx, config, progress=report.stage(0)) as data:
        with torch_context(int(system.random_state), system.n_threads):
            reg, history["regressor"] = stream_training.train_regressor(system, data, device, report.stage(1))
            pf = None
            if system.postfilter:
                pf, history["postfilter"] = stream_training.train_postfilter(system, data, device, report.stage(2))
        tick = report.stage(n_stages - 1)
        tick(0.0, "post-processing tables")
        ctrain, cvalid = streamed.calibration_pieces(system, data, corpus)
        system.motion_sd_, system.gv_, system.band_gains_, hraw, hy = calibration.restoration_tables(
            system, ctrain, cvalid, reg, pf)
        system.feature_config_ = config
        system.input_dim_ = int(data.input_dim)
        system.feature_norm_, system.motion_norm_, system.embedding_norm_ = data.feat_norm, data.mot_norm, None
        system.autoencoder_, system.regressor_, system.postfilter_ = None, reg, pf
        system.range_ = range_from_training([p.motion for p in ctrain], system.motion_norm_.mean_)
        system.mean_pose_ = data.mean_pose
        fps_list = sorted(data.fps_seen)
        del ctrain, cvalid
    fit_idx = [i for i, rid in enumerate(ids) if split[rid] != "test"]
    if system.cross_fit_value and system.speed_shaping and len(fit_idx) >= 2:
        tick(0.3, "cross-fitted speed map")
        keep = budget_subset(corpus, streamed.CALIBRATION_SECONDS, seed=int(system.random_state), indices=fit_idx)
        system.speed_map_ = calibration.cross_fit_speed_map(system, [corpus[i] for i in keep])
    else:
        system.speed_map_ = calibration.validation_speed_map(system, hraw, hy)
    system.output_fps_ = fps_list[0] if len(fps_list) == 1 else float(system.model_fps)
    system.splits_ = {rid: split[rid] for rid in ids}
    system.fps_ = float(system.model_fps)
    system.sample_rate_ = int(corpus[train_idx[0]].audio.sample_rate)
    system.history_ = clean_json(history)
    system.fit_seconds_ = time.perf_counter() - t0
    system.corpus_summary_ = corpus.summary()
    system.fitted_ = True
    tick(1.0, f"done in {system.fit_seconds_:.1f} s")
    return system


__all__ = ["fit_streamed"]
