"""A folder in BEAT2's layout made of planted recordings, of any size, written take by take.

For the whole path through the commands (import, features, training, evaluation with the
dataset's split) and for measuring it at tens of hours without the dataset: real speech tiled to
each take's length (:func:`headmotion.synthetic.tiled_speech`) with head motion made by the planted
process (:func:`headmotion.synthetic.planted_motion`), written as BEAT2 ships its files —
``wave16k/<id>.wav`` (16 kHz), ``smplxflame_30/<id>.npz`` (SMPL-X ``poses`` of width 165 at
``mocap_frame_rate`` 30, the head's rotation on joint 15) with the speech ``extra_speech_s`` longer
than the motion as in the dataset, and ``train_test_split.csv``.  Memory holds one take.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import ParameterError

MOTION_FPS = 30
SAMPLE_RATE = 16000


def _split_of(take: int) -> str:
    """BEAT2's proportions, roughly: per speaker every 10th take test, the next validation."""
    return {0: "test", 1: "val"}.get(take % 10, "train")


def write_planted_beat2(root, *, hours: float, take_minutes: float = 1.0, speakers: int = 4, seed: int = 0,
                        speech_dir=None, extra_speech_s: float = 0.3) -> Path:
    """Write a planted corpus of ``hours`` in BEAT2's layout under ``root``.

    Parameters
    ----------
    root : folder to create (``smplxflame_30/``, ``wave16k/``, ``train_test_split.csv``)
    hours : total motion length
    take_minutes : length of each take (BEAT2's are about 1 minute)
    speakers : number of speakers (ids ``<n>_planted<n>_0_<take>_<take>``), takes dealt round-robin
    seed : seed of the speech tiling and the motion
    speech_dir : speech to tile (default as :func:`headmotion.synthetic.speech_sources`)
    extra_speech_s : seconds the speech runs past the motion (trimmed at import)

    Returns
    -------
    Path of ``root``
    """
    import soundfile as sf

    from ..synthetic import _speech_pool, planted_motion, speech_sources, tiled_speech
    from ..types import Audio

    if hours <= 0 or take_minutes <= 0 or speakers < 1:
        raise ParameterError(f"need hours > 0, take_minutes > 0, speakers >= 1; got {hours}, {take_minutes}, {speakers}")
    n_takes = max(1, int(round(hours * 60.0 / take_minutes)))
    if n_takes < 2 * speakers + 1:  # each speaker's first take is test, the second validation
        raise ParameterError(
            f"hours={hours:g} in takes of {take_minutes:g} min gives {n_takes} take(s) over {speakers} speaker(s), "
            f"none of them for training: the split puts each speaker's first take in test and the second in "
            f"validation, so at least {2 * speakers + 1} takes are needed (hours >= "
            f"{(2 * speakers + 1) * take_minutes / 60.0:.3g}, or fewer speakers or shorter takes)")
    root = Path(root)
    (root / "smplxflame_30").mkdir(parents=True, exist_ok=True)
    (root / "wave16k").mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    pool = _speech_pool(speech_sources(speech_dir), SAMPLE_RATE)
    rows = ["id,type"]
    for k in range(n_takes):
        spk, take = k % speakers, k // speakers
        rid = f"{spk + 1}_planted{spk + 1}_0_{take + 1}_{take + 1}"
        x = tiled_speech(pool, take_minutes * 60.0 + extra_speech_s, sample_rate=SAMPLE_RATE, rng=rng)
        n_motion = int(round(take_minutes * 60.0 * MOTION_FPS))
        motion = planted_motion(Audio(x, SAMPLE_RATE), fps=MOTION_FPS, seed=int(rng.integers(1 << 31)))
        poses = np.zeros((n_motion, 165), np.float32)
        poses[:, 15 * 3:16 * 3] = np.asarray(motion.rotvec[:n_motion], np.float32)
        sf.write(root / "wave16k" / f"{rid}.wav", x, SAMPLE_RATE, subtype="PCM_16")
        np.savez(root / "smplxflame_30" / f"{rid}.npz", poses=poses, trans=np.zeros((n_motion, 3), np.float32),
                 betas=np.zeros(300, np.float32), mocap_frame_rate=np.array(MOTION_FPS),
                 model=np.array("smplx2020"), gender=np.array("neutral"))
        rows.append(f"{rid},{_split_of(take)}")
    (root / "train_test_split.csv").write_text("\n".join(rows) + "\n")
    return root


__all__ = ["write_planted_beat2"]
