"""``motion-match``: head motion *sampled* from speech by choosing recorded movements
(speech-conditioned motion matching; docs/decisions/motion-matching.md).

A regressor predicts the average head; a generative network trembles where a head holds still.
Here the training motion itself is the vocabulary of movements, and the model is a
speech-conditioned way of walking through it (motion matching, Clavet 2016; for speech-driven
gesture, Habibie et al. 2022):

* **Library** (:meth:`MotionMatch.fit`): every training recording's pitch, yaw and roll at 25 fps
  in degrees, its mean pose removed (:func:`~headmotion.motion.angles.centred_degrees`), and, with
  ``mirror``, its copy with yaw and roll negated; beside each frame, its prosody — energy, log F0,
  their deltas and voicing (:data:`PROSODY`, selected by name; standardised).
* **Matching**: every ``hop`` frames the system scores each library frame by how far the prosody
  around it (``context`` frames back to ``lookahead`` frames ahead) is from the prosody around the
  current frame, and how far its pose and velocity are from where the motion is heading; while
  speaking (a voiced share of the hop ≥ 0.2), by how far its next ``hop`` frames miss the pitch
  *goal* (a ridge regression of the pose on the prosody descriptor, scaled to the library's SD;
  ``target_weight``) — frame by frame over the hop (``goal_path``) or at its end only — and in a
  pause by how much it moves (``pause_weight``; with ``pause_speed`` its mean squared speed over
  the hop, else its net displacement: clips that hold).  A frame other than the one that continues
  the clip already playing pays ``switch_cost`` (× ``pause_switch`` in a pause: a head settles or
  shifts between phrases).  One of the ``top_k`` cheapest is drawn from the seed with weight
  ``exp(-(cost - best) / temperature)`` — for a take's first movement among frames at least a hop
  apart (different clips, not one clip's neighbours) — and its motion plays from there.
* **Joins** (inertialisation): when the clip changes, the difference between where the motion was
  going (position and velocity) and where the new clip starts decays as a critically damped spring
  that settles over ``blend`` frames, so a join has neither a step nor a kink; nothing else
  changes the recorded motion.

Same seed, same motion; another seed makes other choices, so ``--samples K`` gives K takes made of
different movements.  Memory is the library (25 frames a second of training motion) and the
output; any length.  A decision reads the speech up to ``hop + lookahead`` frames ahead (1.0 s by
default: the goal over the hop).

**Live** (``live=True``, :class:`MotionMatchStream`): the prosody is the f0e-live set (pitch,
energy, their deltas and voicing, computed incrementally with no lookahead: with ``reader="yin"`` a
frame is final 39 ms after its start, with ``reader="praat"`` 50 ms, with ``reader="praat-path"`` — the
shipped ``stream`` — 40 ms),
smoothed and described from the past only, in the library as at
synthesis; a decision reads the speech up to its own frame, its goal is the pose that speech
asks for, held over the hop, and a hop is a pause when the last ``hop`` frames were mostly
unvoiced.  The system then streams that far behind the audio, and the stream equals ``predict``.
With ``lookahead_ms`` (a voice agent's speech is made before it is played) every decision reads
the speech A = floor(lookahead_ms · 25 / 1000) frames past its own frame — the query's and the
library's descriptors alike, the library re-indexed, not retrained — and the stream comes
A · 40 ms later.

**Frame-by-frame prosody** (``prosody="f0e-live"``, not ``live``; the shipped default): the same
features (the default reads its pitch with Praat in 30 s blocks, ``reader="praat"``), and every decision computed from a window of them around its frame (its reach back and
ahead, :attr:`MotionMatch._reach`) as :class:`WindowStream` computes it when the audio streams in:
the system streams with that lookahead (≈ 1.1 s), a long file is synthesised block by block, and
the stream equals ``predict``.  ``lowpass`` and ``posture_s`` (docs/decisions/default_models.md)
clean the library of a tracker's jitter and keep postures over seconds.

The package by concern: :mod:`.library` (the speech descriptors, clips and the search tables,
with the costs and the draw), :mod:`.walk` (a take's decisions and joins), :mod:`.streams`
(:class:`MotionMatchStream`, :class:`WindowStream`) and :mod:`.estimator` (:class:`MotionMatch`).
"""

from .estimator import MotionMatch
from .library import (AMOUNT_LEAN, CENTRED_FEATURES, FPS, LIVE_FEATURES, LIVE_NAMES, MAX_STEP_DEG, PROSODY, SMOOTH,
                      SPEAKING_SHARE, VOICING, Library, Weights, clean_clips, clip_starts, descriptor_of_last,
                      read_ahead, speech_descriptors)
from .streams import MotionMatchStream, WindowStream, _tail_rows
from .walk import REPEAT_S, WAIT_PAUSE_WEIGHT, WAIT_REPEAT_COST, _Walk

__all__ = ["MotionMatch", "MotionMatchStream", "WindowStream", "PROSODY", "LIVE_NAMES", "speech_descriptors",
           "Library", "Weights", "AMOUNT_LEAN", "CENTRED_FEATURES", "FPS", "LIVE_FEATURES", "MAX_STEP_DEG", "SMOOTH",
           "SPEAKING_SHARE", "VOICING", "clean_clips", "clip_starts", "descriptor_of_last", "read_ahead", "REPEAT_S",
           "WAIT_PAUSE_WEIGHT", "WAIT_REPEAT_COST", "_Walk", "_tail_rows"]
