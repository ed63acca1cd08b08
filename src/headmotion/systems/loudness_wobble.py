"""``loudness-wobble``: the rule a robot conversation app ships for a speaking head, as a baseline.

Reachy Mini's conversation app (pollen-robotics/reachy_mini_conversation_app, ``audio/speech_tapper.py``,
Apache-2.0) moves the robot's head while it speaks by three fixed sine waves whose amplitude follows
the loudness of the speech.  Its rule, as published there (re-implemented here from its parameters,
vectorised over a file):

* every **50 ms** the level of the **last 20 ms** (RMS, dB re full scale);
* a **gate** with hysteresis: on once the level is ≥ −35 dB for 40 ms (one step), off once it is
  ≤ −45 dB for 250 ms (five steps); an envelope ramps up over one step when on and down over five
  when off, followed with a gain of 0.65 per step;
* a **loudness gain**: the level + 4 dB between −46 and −18 dB mapped to 0–1, raised to the power
  0.9, times 1.5;
* **pitch** 2.2 Hz ±4.5°, **yaw** 0.6 Hz ±7.5°, **roll** 1.3 Hz ±2.25°, each times gain × envelope,
  at phases drawn from the seed (the app's small translations are not rotations and are left out).

The steps' values are interpolated to the output frame rate, added to the training data's mean pose.
The seeds are silent on it; it is a baseline of what an app ships, not a model of people: its tie to
the speech is loudness alone (docs/results.md).
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..types import Audio, Motion
from .base import Synthesizer

STEP_S, WINDOW_S = 0.050, 0.020
GATE_ON_DB, GATE_OFF_DB = -35.0, -45.0
GATE_ON_STEPS, GATE_OFF_STEPS = 1, 5          # 40 ms and 250 ms at 50 ms a step
ENV_UP_STEPS, ENV_DOWN_STEPS, ENV_FOLLOW = 1, 5, 0.65
LEVEL_LOW_DB, LEVEL_HIGH_DB, LEVEL_OFFSET_DB, LEVEL_GAMMA, MASTER = -46.0, -18.0, 4.0, 0.9, 1.5
#: (frequency Hz, amplitude degrees) of pitch, yaw, roll
WAVES = ((2.2, 4.5), (0.6, 7.5), (1.3, 2.25))
ANALYSIS_RATE = 16000


def step_levels(x: np.ndarray, sample_rate: int) -> np.ndarray:
    """The level (dB re full scale) of the last :data:`WINDOW_S` at the end of each step."""
    step, win = int(round(STEP_S * sample_rate)), int(round(WINDOW_S * sample_rate))
    n = len(x) // step
    ends = (np.arange(n) + 1) * step
    csum = np.concatenate([[0.0], np.cumsum(np.asarray(x, np.float64) ** 2)])
    starts = np.maximum(ends - win, 0)
    ms = (csum[ends] - csum[starts]) / np.maximum(ends - starts, 1)
    return 20.0 * np.log10(np.sqrt(ms + 1e-12) + 1e-12)


def envelope(levels: np.ndarray) -> np.ndarray:
    """The gated envelope (0–1) at each step (the rule's hysteresis, ramps and follower)."""
    on, above, below, up, down, env = False, 0, 0, 0, 0, 0.0
    out = np.zeros(len(levels))
    for i, db in enumerate(levels):
        if db >= GATE_ON_DB:
            above, below = above + 1, 0
            on = on or above >= GATE_ON_STEPS
        elif db <= GATE_OFF_DB:
            below, above = below + 1, 0
            on = on and below < GATE_OFF_STEPS
        if on:
            up, down = min(ENV_UP_STEPS, up + 1), 0
            target = up / ENV_UP_STEPS
        else:
            down, up = min(ENV_DOWN_STEPS, down + 1), 0
            target = 1.0 - down / ENV_DOWN_STEPS
        env = min(1.0, max(0.0, env + ENV_FOLLOW * (target - env)))
        out[i] = env
    return out


def loudness_gain(levels: np.ndarray) -> np.ndarray:
    t = np.clip((levels + LEVEL_OFFSET_DB - LEVEL_LOW_DB) / (LEVEL_HIGH_DB - LEVEL_LOW_DB), 0.0, 1.0)
    return t ** LEVEL_GAMMA * MASTER


def wobble(x: np.ndarray, sample_rate: int, *, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(times of the steps in seconds, pitch/yaw/roll in radians at each step) of speech ``x``."""
    levels = step_levels(x, sample_rate)
    amp = loudness_gain(levels) * envelope(levels)
    t = (np.arange(len(levels)) + 1) * STEP_S
    phases = np.random.default_rng(seed).random(3) * 2.0 * np.pi
    angles = np.stack([np.radians(a) * amp * np.sin(2.0 * np.pi * f * t + ph)
                       for (f, a), ph in zip(WAVES, phases)], axis=1)
    return t, angles


class LoudnessWobble(Synthesizer):
    """The loudness-scaled sine wobble (module docstring).

    Parameters
    ----------
    fps : float, output frames per second
    seed : int, default synthesis seed (the waves' phases)
    """

    name = "loudness-wobble"

    def __init__(self, *, fps: float = 25.0, seed: int = 0):
        self._store_params(locals())

    def _validate_params(self) -> None:
        if not (isinstance(self.fps, (int, float)) and 1.0 <= float(self.fps) <= 240.0):
            raise ParameterError(f"loudness-wobble's fps must be from 1 to 240 frames a second; got {self.fps!r}")

    def fit(self, corpus, *, progress=None):
        from ..motion.control import mean_pose_of

        recs = self._training_recordings(corpus)
        self.fps_ = float(self.fps)
        self.sample_rate_ = ANALYSIS_RATE
        self.mean_pose_ = mean_pose_of([r.motion.rotvec for r in recs])
        self.fitted_ = True
        if progress is not None:
            progress(1, 1, "loudness-wobble: the training data's mean pose")
        return self

    def _predict(self, audio: Audio, *, seed: int) -> Motion:
        from ..io.audio import resample
        from ..rotations import pitch_yaw_roll_to_rotvec

        x = np.asarray(audio.samples, np.float64)
        if audio.sample_rate != self.sample_rate_:
            x = resample(x, audio.sample_rate, self.sample_rate_)
        n = int(round(len(x) / self.sample_rate_ * self.fps_))
        t, angles = wobble(x, self.sample_rate_, seed=seed)
        frames = np.arange(n) / self.fps_
        pyr = np.zeros((n, 3))
        if len(t):
            pyr = np.stack([np.interp(frames, np.concatenate([[0.0], t]), np.concatenate([[0.0], angles[:, j]]))
                            for j in range(3)], axis=1)
        pyr += self.mean_pose_
        return Motion(pitch_yaw_roll_to_rotvec(pyr[:, 0], pyr[:, 1], pyr[:, 2]), self.fps_)

    def _get_state(self):
        return {"params": self.get_params(), "fps": self.fps_, "sample_rate": self.sample_rate_}, {}

    def _set_state(self, config, arrays):  # noqa: ARG002  (the rule holds no arrays)
        self.__init__(**config["params"])
        self.fps_ = float(config["fps"])
        self.sample_rate_ = int(config["sample_rate"])


__all__ = ["LoudnessWobble", "wobble", "envelope", "step_levels", "loudness_gain", "WAVES"]
