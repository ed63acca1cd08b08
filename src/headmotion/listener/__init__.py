"""A head that listens: while another person speaks and this head does not, it holds an attentive
posture and nods at the other's prosodic back-channel cues (docs/listening.md).

* :mod:`.cues`  — Ward & Tsukahara (2000)'s rule for back-channel cues: a region of low pitch;
* :mod:`.nods`  — nods cut from the recorded motion a motion-matching model holds;
* :mod:`.head`  — the listening layer over a model's motion, offline and on a stream.

The seeds are silent on listening; the rule is the published baseline of the field.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError

#: the listening amount: 0 the head only waits while the other speaks (as with nothing heard),
#: 1 an attentive posture and nods at the other's cues, up to 3 (more and larger nods)
LISTENING_RANGE = (0.0, 3.0)
DEFAULT_LISTENING = 1.0


def check_listening(v) -> float:
    """The listening amount ``v`` as a float, or a :class:`~headmotion.errors.ParameterError`
    naming the range (here, not in :mod:`.head`: every synthesis checks it, hearing or not)."""
    ok = not isinstance(v, bool) and isinstance(v, (int, float, np.integer, np.floating))
    if not ok or not math.isfinite(v) or not LISTENING_RANGE[0] <= v <= LISTENING_RANGE[1]:
        raise ParameterError(f"listening (--listening) must be a number from {LISTENING_RANGE[0]:g} to {LISTENING_RANGE[1]:g}; "
                             f"got {v!r:.40}")
    return float(v)


__all__ = ["LISTENING_RANGE", "DEFAULT_LISTENING", "check_listening"]
