"""``motion-flow``: head motion *sampled* from speech by conditional flow matching over motion
windows (:mod:`headmotion.models.flow_net`; docs/decisions/generative-system.md).

Instead of regressing the average head and repairing its statistics afterwards, the system learns
the distribution of whole movements — nods, holds, glances and their timing — given the speech,
and draws from it: each seed is a different take.

* **Motion**: pitch, yaw, roll at 25 fps in degrees, each recording's mean pose removed and every
  axis divided by its SD over the training motion.  **Speech**: 19 features at the same rate —
  energy, 12 mel cepstra and Δenergy (:func:`headmotion.features.spectral.mfcc`), log F0, energy,
  their deltas and voicing (:func:`headmotion.features.prosody.f0e`) — standardised with the
  training corpus's mean and SD.
* **Training** (:meth:`MotionFlow.fit`): random windows of ``window`` frames with augmentation
  (yaw and roll mirrored together, time stretch ±10 %, amplitude ×e^N(0, 0.1), feature noise);
  the speech of ``cond_dropout`` of the windows is dropped (the network is also an unconditional
  motion prior, and sampling uses classifier-free guidance ``guidance``); half the windows show a
  random known prefix.  Early stopping on recordings of speakers held out of training
  (``valid_share``).  On any device the randomness is drawn on the CPU and convolutions run in
  full float32 (no TF32), so a GPU trains the CPU's model up to rounding.
* **Synthesis**: windows of ``window`` frames, each after the first continuing the previous one's
  last ``prefix`` frames (a known prefix, held during sampling), so any length is made in bounded
  memory; the last window is moved back to end at the input's end.  Each window is
  ``sampling_steps`` Euler steps from Gaussian noise drawn from ``seed``; the network predicts the
  flow's velocity (``target="velocity"``; ``"motion"``: the clean window, less detectable on one
  fold set but a third of the amplitude and nearly one take across seeds) and at every step the
  window's start is carried on from the prefix's end over ``join_frames`` frames, so windows join
  without a step.  No stage after the network changes its output.

The system does not stream: a window's frames are drawn jointly from the whole window's speech
(``window − prefix`` frames, 3.2 s by default, of lookahead), more than a live head can wait for.
"""

from __future__ import annotations

import contextlib
import copy
import time
from typing import Any, ClassVar

import numpy as np

from ..align import n_frames as _n_frames
from ..devices import DEVICES, resolve_device
from ..errors import ParameterError
from ..motion.angles import centred_degrees
from ..motion.control import mean_pose_of
from ..rotations import pitch_yaw_roll_to_rotvec
from ..types import Audio, Motion
from .base import Synthesizer
from .constraints import Options, check_params, real, whole

FPS = 25.0
#: the speech features: (feature set, extractor parameters, columns kept)
FEATURES = (("mfcc", {}, list(range(14))), ("f0e", {"voicing": True}, [0, 1, 2, 3, 6]))
#: what the network outputs: the flow's velocity, or the clean motion window
TARGETS = ("velocity", "motion")
#: parameters of models saved before these existed: the values that sample as those models did
SAVED_BEFORE = {"target": "velocity", "join_frames": 0, "inpaint": "hold"}
#: how a window's known prefix enters sampling: held and shown to the network, or replaced noised
INPAINT = ("hold", "replace")


def speech_features(audio: Audio, n: int) -> np.ndarray:
    """The raw ``(n, 19)`` speech features of ``audio`` at 25 fps (see the module docstring)."""
    from ..features import extract

    cols = [np.asarray(extract(name, audio, fps=FPS, n_frames=n, **params).values, dtype=np.float32)[:, keep]
            for name, params, keep in FEATURES]
    return np.concatenate(cols, axis=1)


def motion_degrees(motion: Motion, n: int) -> np.ndarray:
    """``(n, 3)`` pitch, yaw, roll in degrees at 25 fps, the recording's mean pose removed."""
    return centred_degrees(motion, n, FPS)


@contextlib.contextmanager
def _torch_threads(n_threads: int | None):
    import torch

    prev = torch.get_num_threads()
    if n_threads:
        torch.set_num_threads(int(n_threads))
    try:
        yield
    finally:
        torch.set_num_threads(prev)


def speaker_split(recs, share: float, seed: int) -> np.ndarray:
    """True for the recordings held out for early stopping: whole speakers, about ``share`` of
    the frames (a recording of its own when there is one speaker; none when one recording)."""
    if share <= 0 or len(recs) < 2:
        return np.zeros(len(recs), bool)
    speakers = sorted({r.speaker for r in recs})
    keys = speakers if len(speakers) >= 2 else [r.id for r in recs]
    key_of = (lambda r: r.speaker) if len(speakers) >= 2 else (lambda r: r.id)
    dur = {k: sum(len(r.motion) / r.motion.fps for r in recs if key_of(r) == k) for k in keys}
    order = np.random.default_rng(seed).permutation(len(keys))
    total, held, chosen = sum(dur.values()), 0.0, set()
    for i in order:
        if held >= share * total or len(chosen) == len(keys) - 1:
            break
        chosen.add(keys[i])
        held += dur[keys[i]]
    return np.array([key_of(r) in chosen for r in recs])


class WindowSampler:
    """Random training windows ``(motion (B, 3, W), speech (B, D, W), valid (B, 1, W))`` from
    normalised recordings, with the augmentation of the module docstring."""

    def __init__(self, data: list[tuple[np.ndarray, np.ndarray]], window: int, *, augment: bool):
        self.data, self.window, self.augment = data, int(window), augment
        lens = np.array([len(m) for m, _ in data], dtype=float)
        self.p = lens / lens.sum()

    def batch(self, rng: np.random.Generator, size: int):
        W = self.window
        D = self.data[0][1].shape[1]
        mot, cond, valid = np.zeros((size, 3, W), np.float32), np.zeros((size, D, W), np.float32), np.zeros((size, 1, W), np.float32)
        for b in range(size):
            m, f = self.data[rng.choice(len(self.data), p=self.p)]
            s = float(np.exp(rng.uniform(-0.1, 0.1))) if self.augment else 1.0
            src = min(len(m), int(round(W * s)))
            a = int(rng.integers(0, len(m) - src + 1))
            n = min(W, max(2, int(round(src / s))))
            pos = np.linspace(a, a + src - 1, n)
            mm = np.stack([np.interp(pos, np.arange(len(m)), m[:, k]) for k in range(3)])
            ff = np.stack([np.interp(pos, np.arange(len(f)), f[:, k]) for k in range(D)])
            if self.augment:
                if rng.random() < 0.5:
                    mm[1:] *= -1.0
                mm *= float(np.exp(rng.normal(0.0, 0.1)))
                ff = ff + rng.normal(0.0, 0.1, ff.shape)
            mot[b, :, :n], cond[b, :, :n], valid[b, :, :n] = mm, ff, 1.0
        return mot, cond, valid

    @staticmethod
    def masks(rng: np.random.Generator, valid: np.ndarray, cond_dropout: float):
        """Keep flags ``(B,)`` (speech shown) and prefix masks ``(B, 1, W)`` (a random known prefix on
        half the windows that have at least 20 valid frames)."""
        B, _, W = valid.shape
        keep = (rng.random(B) >= cond_dropout).astype(np.float32)
        pm = np.zeros_like(valid)
        n_valid = valid.sum(axis=(1, 2)).astype(int)
        for b in range(B):
            if n_valid[b] >= 20 and rng.random() < 0.5:
                pm[b, 0, :int(rng.integers(4, max(5, n_valid[b] - 10)))] = 1.0
        return keep, pm


class MotionFlow(Synthesizer):
    """Speech-conditioned rectified flow over motion windows (see the module docstring).

    Parameters
    ----------
    window, prefix : int, frames (25 fps) of a window and of the known prefix it continues
    hidden, n_blocks : int, width and depth of the network
    cond_dropout : float, share of training windows without speech (the motion prior)
    smooth_weight : float, weight of the frame-to-frame step loss (:func:`~headmotion.models.flow_net.flow_loss`)
    guidance : float, classifier-free guidance at synthesis (1 = plain conditional flow)
    sampling_steps : int, Euler steps per window
    train_steps, batch_size, learning_rate : training schedule (Adam, cosine decay)
    valid_share : float, share of the training frames (whole speakers) kept for early stopping
    eval_every : int, steps between validations
    augment : bool, mirror / stretch / amplitude / feature-noise augmentation
    target : "velocity" (the network predicts the flow's velocity) or "motion" (the clean window)
    join_frames : int, frames over which each sampling step carries a window on from its prefix's
        end (0: none; :func:`~headmotion.models.flow_net.join_offsets`)
    inpaint : "hold" (the prefix is held and shown to the network) or "replace" (noised to the flow
        time at every step, replacement-style)
    device : "auto", "cpu" or "cuda" (training and synthesis; torch decides what "auto" sees)
    random_state : int, training randomness; seed : int, default synthesis seed
    n_threads : int or None, torch threads during fit and predict
    """

    name: ClassVar[str] = "motion-flow"
    capabilities: ClassVar[frozenset[str]] = frozenset()

    def __init__(self, *, window: int = 100, prefix: int = 20, hidden: int = 48, n_blocks: int = 6,
                 cond_dropout: float = 0.5, smooth_weight: float = 0.0, guidance: float = 2.5, sampling_steps: int = 8,
                 train_steps: int = 600, batch_size: int = 32, learning_rate: float = 2e-3,
                 valid_share: float = 0.15, eval_every: int = 50, augment: bool = True, device: str = "auto",
                 target: str = "velocity", join_frames: int = 8, inpaint: str = "hold",
                 random_state: int = 0, seed: int = 0, n_threads: int | None = None):
        self._store_params(locals())

    # -- parameters ------------------------------------------------------------------------------
    #: what each parameter may be (:mod:`.constraints`)
    _parameter_constraints: ClassVar[dict] = {
        "window": [whole(8)], "prefix": [whole(1)], "hidden": [whole(8)],
        **{k: [whole(1)] for k in ("n_blocks", "sampling_steps", "train_steps", "batch_size", "eval_every")},
        **{k: [whole(0)] for k in ("random_state", "join_frames", "seed")},
        "cond_dropout": [real(0.0, 1.0, closed="left")], "valid_share": [real(0.0, 0.9, closed="left")],
        "guidance": [real(0)], "smooth_weight": [real(0)], "learning_rate": [real(0, closed="neither")],
        "target": [Options(TARGETS)], "inpaint": [Options(INPAINT)], "device": [Options(tuple(DEVICES))],
        "n_threads": [whole(1), None],
    }

    def _validate_params(self) -> None:
        check_params(self, self._parameter_constraints)
        if self.prefix >= self.window // 2:
            raise ParameterError(f"the 'prefix' parameter of {self.name} must be below half the window "
                                 f"({self.window}); got {self.prefix}")

    # -- fitting ---------------------------------------------------------------------------------
    def fit(self, corpus, *, progress=None) -> "MotionFlow":
        """Train the flow network on ``corpus`` (any number of speakers; see the module docstring;
        ``progress`` as in :meth:`Synthesizer.fit <headmotion.systems.base.Synthesizer.fit>`)."""
        import torch

        from ..models.flow_net import FlowNet

        recs = self._training_recordings(corpus)
        t0 = time.perf_counter()
        device = resolve_device(self.device)
        raw = []
        for r in recs:
            n = _n_frames(len(r.audio.samples), r.audio.sample_rate, FPS)
            raw.append((motion_degrees(r.motion, n), speech_features(r.audio, n)))
        feats = np.concatenate([f for _, f in raw]).astype(np.float64)
        self.feat_mean_ = feats.mean(axis=0)
        self.feat_std_ = np.maximum(feats.std(axis=0), 1e-6)
        self.scale_ = np.maximum(np.concatenate([m for m, _ in raw]).std(axis=0), 1e-3)
        data = [((m / self.scale_).astype(np.float32), ((f - self.feat_mean_) / self.feat_std_).astype(np.float32))
                for m, f in raw]
        held = speaker_split(recs, float(self.valid_share), int(self.random_state))
        train = [d for d, h in zip(data, held) if not h]
        valid = [d for d, h in zip(data, held) if h]
        from ..models.nets import exact_float32

        with _torch_threads(self.n_threads), torch.random.fork_rng(devices=[]), exact_float32():
            torch.random.default_generator.manual_seed(int(self.random_state))
            net = FlowNet(feats.shape[1], hidden=int(self.hidden), n_blocks=int(self.n_blocks)).to(device)
            self.train_log_ = self._train(net, train, valid, device, progress)
        self.net_ = net.cpu().eval()
        self.n_cond_ = int(feats.shape[1])
        self.mean_pose_ = mean_pose_of([r.motion.rotvec for r in recs])
        self.fps_, self.sample_rate_ = FPS, int(recs[0].audio.sample_rate)
        self.corpus_summary_ = corpus.summary() if hasattr(corpus, "summary") else None
        self.fit_warnings_ = [] if valid else ["motion-flow: no held-out speakers for early stopping "
                                               "(the last step's network is kept)"]
        self.fit_seconds_ = time.perf_counter() - t0
        self.fitted_ = True
        return self

    def _train(self, net, train, valid, device, progress) -> dict[str, Any]:
        import torch

        from ..models.flow_net import flow_loss
        from ..models.train_speed import Speed

        rng = np.random.default_rng(int(self.random_state))
        sampler = WindowSampler(train, int(self.window), augment=bool(self.augment))
        gen = torch.Generator().manual_seed(int(self.random_state))  # the CPU's on every device: the same draws
        vbatches = []
        if valid:
            vs, vrng = WindowSampler(valid, int(self.window), augment=False), np.random.default_rng(12345)
            for _ in range(4):
                mot, cond, val = vs.batch(vrng, 64)
                keep, pm = WindowSampler.masks(vrng, val, 0.0)
                vbatches.append([torch.from_numpy(a).to(device) for a in (mot, cond, keep, pm, val)])
        opt = Speed(device).adam(net.parameters(), float(self.learning_rate))  # fused on a GPU
        steps = int(self.train_steps)
        sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda i: 0.1 + 0.9 * 0.5 * (1 + np.cos(np.pi * min(i, steps) / steps)))
        best, best_state, history = np.inf, None, []
        for step in range(1, steps + 1):
            net.train()
            mot, cond, val = sampler.batch(rng, int(self.batch_size))
            keep, pm = WindowSampler.masks(rng, val, float(self.cond_dropout))
            args = [torch.from_numpy(a).to(device) for a in (mot, cond, keep, pm, val)]
            loss = flow_loss(net, args[0], args[1], args[2], args[3], args[4], generator=gen,
                             smooth_weight=float(self.smooth_weight), predict=self.target)
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(net.parameters(), 1.0)
            opt.step()
            sched.step()
            if vbatches and (step % int(self.eval_every) == 0 or step == steps):
                net.eval()
                vgen = torch.Generator().manual_seed(777)
                with torch.no_grad():
                    v = float(np.mean([flow_loss(net, *b, generator=vgen, predict=self.target).item()
                                       for b in vbatches]))
                history.append((step, float(loss.item()), v))
                if v < best:
                    best, best_state = v, copy.deepcopy(net.state_dict())
            if progress is not None and step % 50 == 0:
                progress(step, steps, f"motion-flow step {step}/{steps}")
        if best_state is not None:
            net.load_state_dict(best_state)
        best_step = min(history, key=lambda h: h[2])[0] if history else steps
        return {"history": history, "best_step": int(best_step), "device": device}

    # -- synthesis -------------------------------------------------------------------------------
    def _features(self, audio: Audio, n: int) -> np.ndarray:
        return ((speech_features(audio, n) - self.feat_mean_) / self.feat_std_).astype(np.float32)

    def generate(self, feats: np.ndarray, seed: int) -> np.ndarray:
        """Normalised motion ``(T, 3)`` for normalised speech features ``(T, D)`` (window by window,
        each continuing the previous one's end; see the module docstring)."""
        import torch

        from ..models.flow_net import sample_window

        T, W, P = len(feats), int(self.window), int(self.prefix)
        rng = np.random.default_rng(int(seed))
        device = resolve_device(self.device)
        net = self.net_.to(device)
        out = np.zeros((max(T, W), 3), np.float32)
        cond_all = np.zeros((max(T, W), feats.shape[1]), np.float32)
        cond_all[:T] = feats
        done, start = 0, 0
        with _torch_threads(self.n_threads):
            while True:
                start = min(start, max(T, W) - W)
                pm = np.zeros((1, 1, W), np.float32)
                pm[0, 0, :done - start] = 1.0
                noise = rng.standard_normal((1, 3, W)).astype(np.float32)
                args = [torch.from_numpy(a).to(device) for a in
                        (noise, cond_all[start:start + W].T[None].copy(), out[start:start + W].T[None].copy(), pm)]
                x = sample_window(net, args[0], args[1], args[2], args[3], n_steps=int(self.sampling_steps),
                                  guidance=float(self.guidance), predict=self.target,
                                  join_frames=int(self.join_frames), replace=self.inpaint == "replace")
                out[start:start + W] = x[0].cpu().numpy().T
                done = start + W
                if done >= T:
                    break
                start = done - P
        self.net_ = net.cpu()
        return out[:T]

    def _predict(self, audio: Audio, *, seed: int) -> Motion:
        n = _n_frames(len(audio.samples), audio.sample_rate, FPS)
        if n == 0:
            return Motion(np.zeros((0, 3)), FPS)
        x = self.generate(self._features(audio, n), seed)
        pyr = np.radians(x.astype(np.float64) * self.scale_) + self.mean_pose_
        return Motion(pitch_yaw_roll_to_rotvec(pyr[:, 0], pyr[:, 1], pyr[:, 2]), FPS)

    # -- persistence -----------------------------------------------------------------------------
    def _get_state(self):
        from ..models.nets import state_to_arrays

        config = {"params": self.get_params(), "n_cond": self.n_cond_, "sample_rate": self.sample_rate_,
                  "fps": self.fps_, "train_log": self.train_log_}
        arrays = {"feat_mean": self.feat_mean_, "feat_std": self.feat_std_, "scale": self.scale_,
                  **state_to_arrays(self.net_, "net.")}
        return config, arrays

    def _set_state(self, config, arrays):
        from ..models.flow_net import FlowNet
        from ..models.nets import arrays_to_state

        params = dict(config["params"])
        for k in self._param_names():
            setattr(self, k, params.get(k, SAVED_BEFORE.get(k, getattr(type(self)(), k))))
        self.n_cond_, self.sample_rate_, self.fps_ = int(config["n_cond"]), int(config["sample_rate"]), float(config["fps"])
        self.train_log_ = config.get("train_log")
        self.feat_mean_ = np.asarray(arrays["feat_mean"], dtype=np.float64)
        self.feat_std_ = np.asarray(arrays["feat_std"], dtype=np.float64)
        self.scale_ = np.asarray(arrays["scale"], dtype=np.float64)
        net = FlowNet(self.n_cond_, hidden=int(self.hidden), n_blocks=int(self.n_blocks))
        arrays_to_state(net, arrays, "net.")
        self.net_ = net.eval()
        self.fit_warnings_ = []


__all__ = ["MotionFlow", "speech_features", "motion_degrees", "speaker_split", "WindowSampler", "resolve_device"]
