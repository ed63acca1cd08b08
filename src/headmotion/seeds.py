"""Synthesis seeds: the default and the one rule every front end and system checks them by.

A synthesis seed picks a take: the same seed, the same motion.  ``headmotion synth``, Python's
:func:`headmotion.synthesize`, the service and every system's ``predict`` / ``stream`` accept the
same seeds — whole numbers from 0 to :data:`SEED_MAX` (numpy's legacy seeds, which some systems
use) — and with ``samples=K`` sample ``k`` uses ``seed + k``, so ``seed + K - 1`` must fit too.
A seed left out (None) is the model's own ``seed`` parameter, or :data:`DEFAULT_SEED` for a model
without one.  :func:`resolve_seed` applies both rules, once per synthesis: in a system's public
``predict`` / ``stream``, or in :func:`headmotion.synthesize` / :func:`headmotion.open_stream`,
which then call the system's ``predict_seeded`` / ``stream_seeded`` with the seed it gave.
"""

from __future__ import annotations

import numpy as np

from .errors import ParameterError

#: the seed used when none is given and the model has no ``seed`` parameter
DEFAULT_SEED = 0
#: the largest seed (with ``samples=K``: ``seed + K - 1`` at most this)
SEED_MAX = 2 ** 32 - 1


def check_seed(seed, samples: int = 1, *, allow_none: bool = False) -> None:
    """Refuse a seed outside ``0 … SEED_MAX`` (with ``samples=K``: ``seed + K - 1`` at most
    :data:`SEED_MAX`) and a sample count below 1 (:class:`ParameterError` with the range);
    ``allow_none``: None passes (the model's own seed)."""
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise ParameterError(f"samples (--samples) must be a whole number >= 1; got {samples!r}")
    if seed is None and allow_none:
        return
    top = SEED_MAX - (int(samples) - 1)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= top:
        more = f" (seed + samples - 1 at most {SEED_MAX})" if samples > 1 else ""
        raise ParameterError(f"seed (--seed) must be a whole number from 0 to {top}{more}; got {seed!r:.40}")


def model_seed(model, seed) -> int:
    """The seed a synthesis with ``model`` uses: ``seed``, or when None the model's ``seed``
    parameter (None there too: :data:`DEFAULT_SEED`)."""
    if seed is not None:
        return int(seed)
    own = getattr(model, "seed", None)
    return DEFAULT_SEED if own is None else int(own)


def resolve_seed(model, seed, samples: int = 1) -> int:
    """The seed a synthesis with ``model`` uses (the rule of :func:`model_seed`), checked by
    :func:`check_seed` with ``samples`` — the seed given, or the model's own that fills in for None."""
    if seed is None:
        own = getattr(model, "seed", None)
        seed = DEFAULT_SEED if own is None else own
    check_seed(seed, samples)
    return int(seed)


__all__ = ["DEFAULT_SEED", "SEED_MAX", "check_seed", "model_seed", "resolve_seed"]
