"""The level beside a coupling figure: the same motion library read by Praat.

A model's cross-speaker coupling excess says little on its own: how far above the shift null is
good depends on the voices, the corpus and the speech side of the measure.  The level every
``motion-match`` figure is put beside is its **Praat-read library**: the same system with the same
settings, built the same way on the same training recordings, matching Praat's whole-file F0,
energy and voicing (``prosody="f0e"``) instead of the frame-by-frame reading.  It is the best
reading of the voice known for the library, so a model's *ratio to the level* (its excess over
the level's, same speech side, same seeds) says how much of what the library can follow the model
follows.  The recorded heads stay the other level where there are any.

Only what ``prosody="f0e"`` refuses is changed besides the flag: ``live`` (a causal stream reads
the speech frame by frame; Praat reads the whole file) is turned off, and with it a live model's
``lookahead_ms`` (set to 0: a model that is not live reads its ``lookahead`` ahead already).  The
settings of the frame-by-frame reading (``reader``, ``voicing_threshold``, ``pitch_jump``,
``centred``) are kept: with ``f0e`` they are not read.

    >>> level = praat_read_level(load_model("default"), corpus)      # fitted on ``corpus``
    >>> ratio(0.20, 0.25)                                             # 0.8
"""

from __future__ import annotations

import math
import warnings

from ...errors import ParameterError

#: the level's label
LEVEL = "praat-read library"
#: the system whose library can be read by Praat
LEVEL_SYSTEM = "motion-match"


def level_name(name: str) -> str:
    """The label of the level of the model or system called ``name``."""
    return f"{LEVEL} ({name})"


def has_level(system_name: str, params: dict) -> bool:
    """Whether a system with these parameters has a Praat-read twin (a ``motion-match`` that does
    not read Praat already)."""
    return system_name == LEVEL_SYSTEM and "prosody" in params and not _reads_praat(params)


def _reads_praat(params: dict) -> bool:
    return params.get("prosody") == "f0e" or (params.get("prosody") is None and not params.get("live"))


def praat_twin_params(params: dict) -> dict:
    """``motion-match`` parameters with Praat's whole-file prosody (``prosody="f0e"``; ``live`` off,
    which it refuses, and ``lookahead_ms`` 0, which only a live model takes; everything else as
    given).

    Raises
    ------
    ParameterError — not ``motion-match``'s parameters, or they read Praat already
    """
    if "prosody" not in params:
        raise ParameterError(f"a Praat-read level exists only for {LEVEL_SYSTEM} (its 'prosody' parameter); "
                             f"got parameters {sorted(params)}")
    if _reads_praat(params):
        raise ParameterError("these settings read Praat's f0e already: the model is its own Praat-read level")
    out = dict(params)
    out["prosody"] = "f0e"
    out["live"] = False
    if out.get("lookahead_ms"):
        out["lookahead_ms"] = 0.0
    return out


def praat_read_level(model, corpus):
    """The Praat-read twin of a trained ``motion-match`` model, fitted on ``corpus``.

    Parameters
    ----------
    model : MotionMatch — a trained model (a shipped one or a model file)
    corpus : Corpus — the recordings its library is built from (the model's own training
        recordings, for a level of the same library)

    Returns
    -------
    MotionMatch — fitted, ``prosody="f0e"``

    Raises
    ------
    ParameterError — not a ``motion-match`` model, an adapted one (its library mixes a speaker's
        recordings into a base it was not built from), or one that reads Praat already
    """
    from ...systems.base import create

    if getattr(model, "name", None) != LEVEL_SYSTEM:
        raise ParameterError(f"a Praat-read level exists only for {LEVEL_SYSTEM} models; got "
                             f"{getattr(model, 'name', type(model).__name__)!r}")
    if getattr(model, "lib_own_", None) is not None:
        raise ParameterError("an adapted model has no Praat-read level: its library is a base model's plus the "
                             "speaker's recordings, which this corpus does not rebuild")
    twin = create(LEVEL_SYSTEM, **praat_twin_params(model.get_params()))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return twin.fit(corpus)


def ratio(excess: float, level_excess: float) -> float:
    """``excess / level_excess``; nan when the level is not above its null (excess ≤ 0 or nan): a
    level the library does not reach is no level to divide by."""
    if not (math.isfinite(excess) and math.isfinite(level_excess)) or level_excess <= 0:
        return float("nan")
    return float(excess / level_excess)


def level_specs(specs, corpus) -> tuple[list, dict[str, str], list[str]]:
    """The levels of ``evaluate``'s conditions: for each ``motion-match`` condition its Praat-read
    twin, with the same seed name (the same training and synthesis seeds: paired).

    * a system trained per fold (``motion-match[...]``): the twin is trained on the same folds;
    * a trained model (``default``, ``stream``, a model file): the twin is fitted once, here, on
      ``corpus`` — the evaluated corpus, which for the shipped models given without ``mead_lrs3``
      is the recordings they were built from — and scored as it is in every fold, as the model is.

    Parameters
    ----------
    specs : the :class:`~.condition_specs.ConditionSpec` of the evaluated conditions
    corpus : Corpus — the evaluated corpus

    Returns
    -------
    (level specs, {condition: its level's name}, notes: one line per level or per refusal)
    """
    from ...systems.base import load_model
    from ...systems.spec import SystemFactory
    from .condition_specs import ConditionSpec

    out, of, notes = [], {}, []
    for spec in specs:
        if spec.kind == "system" and isinstance(spec.target, SystemFactory):
            params = spec.target().get_params()
            if not has_level(spec.target.name, params):
                continue
            twin = ConditionSpec(level_name(spec.name), "system",
                                 SystemFactory(LEVEL_SYSTEM, praat_twin_params(params)), spec.seed_name)
            notes.append(f"{twin.name}: trained on every fold as {spec.name} is")
        elif spec.kind == "model":
            model = load_model(spec.target)
            if getattr(model, "name", None) != LEVEL_SYSTEM or not has_level(LEVEL_SYSTEM, model.get_params()):
                continue
            try:
                fitted = praat_read_level(model, corpus)
            except ParameterError as exc:
                notes.append(f"{spec.name}: no level ({exc})")
                continue
            twin = ConditionSpec(level_name(spec.name), "fitted", fitted, spec.seed_name)
            notes.append(f"{twin.name}: fitted once on the evaluated corpus ({len(corpus)} recordings), scored as "
                         f"{spec.name} is")
        else:
            continue
        out.append(twin)
        of[spec.name] = twin.name
    return out, of, notes


#: ``level_variants``' level: every variant's own twin
EACH = "each"


def level_variants(variants: dict, level: str | None = EACH) -> tuple[dict, dict]:
    """``motion-match`` variants (name → parameters, as the choice scripts take them) with their
    Praat-read twins added after them, and variant → the name of its level.

    Parameters
    ----------
    variants : name → ``motion-match`` parameters
    level : None (no level), :data:`EACH` (every variant's own twin; a variant that reads Praat
        already is its own level) or a variant's name (that variant's twin, the level of every one)

    Returns
    -------
    (variants and twins, {variant: its level's name})

    Raises
    ------
    ParameterError — ``level`` names no variant
    """
    from ...systems.base import create

    if level is None:
        return dict(variants), {}
    if level != EACH and level not in variants:
        raise ParameterError(f"the level {level!r} is not one of the variants {sorted(variants)}")
    out, of = dict(variants), {}
    for name, params in variants.items():
        if level != EACH and name != level:
            continue
        full = create(LEVEL_SYSTEM, **params).get_params()
        if has_level(LEVEL_SYSTEM, full):
            out[level_name(name)] = praat_twin_params(full)
            of[name] = level_name(name)
        else:
            of[name] = name
    if level != EACH:
        of = {name: of[level] for name in variants}
    return out, of


__all__ = ["LEVEL", "LEVEL_SYSTEM", "EACH", "level_name", "has_level", "praat_twin_params", "praat_read_level", "ratio",
           "level_specs", "level_variants"]
