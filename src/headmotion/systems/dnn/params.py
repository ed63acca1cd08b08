"""The DNN systems' product defaults and the checks of their parameters."""

from __future__ import annotations

import math

import numpy as np

from ...errors import ParameterError

#: the model's frame rate (the paper's: 100 Hz motion capture, 10 ms feature shift)
MODEL_FPS = 100.0
#: share of the training variance carried by the slow posture component, and its time constant (s)
DEFAULT_DRIFT_SHARE = 0.3
DEFAULT_DRIFT_TAU_S = 4.0
#: factor on the slowest (< 0.5 Hz) band's restoring gain at synthesis
DEFAULT_SLOW_BAND_GAIN = 1.15
#: idle level in pauses
DNN_IDLE = 0.45
#: parameters that switch every addition to the paper off (the paper's protocols use them)
PAPER_PARAMS = {"variance_restore": False, "drift_share": 0.0, "idle": None, "speed_shaping": False, "range_limit": False}


def _pos_int(system, name: str, lo: int = 1) -> None:
    v = getattr(system, name)
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
        raise ParameterError(f"the {name!r} parameter of {system.name} must be an int >= {lo}; got {v!r}")


def _sizes(system, name: str) -> None:
    v = getattr(system, name)
    try:
        ok = all(not isinstance(h, bool) and int(h) == h and h >= 1 for h in v)
    except TypeError:
        ok = False
    if not ok:
        raise ParameterError(f"the {name!r} parameter of {system.name} must be a sequence of layer sizes >= 1; got {v!r}")


def _number(system, name: str, ok, expected: str) -> None:
    v = getattr(system, name)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not ok(v):
        raise ParameterError(f"the {name!r} parameter of {system.name} must be {expected}; got {v!r}")


def check_network_params(system) -> None:
    """The networks' and training's parameters (sizes, epochs, rates)."""
    if system.alpha_fixed and system.alpha not in (None, system.default_alpha):
        raise ParameterError(
            f"{system.name} is the autoencoder with alpha = {system.default_alpha:g}; use the 'cccae' system for "
            f"another alpha (got {system.alpha!r})")
    for n in ("embedding_dim", "batch_size", "max_epochs", "ae_max_epochs", "patience", "postfilter_code"):
        _pos_int(system, n)
    for n in ("context", "pretrain_epochs", "random_state"):
        _pos_int(system, n, 0)
    _pos_int(system, "segment", 2)
    _pos_int(system, "cca_batch_size", 2)
    for n in ("ae_hidden", "regressor_hidden", "postfilter_hidden"):
        _sizes(system, n)
    if system.n_threads is not None:
        _pos_int(system, "n_threads")
    if not 0 <= float(system.dropout) < 1:
        raise ParameterError(f"the 'dropout' parameter of {system.name} must be in [0, 1); got {system.dropout!r}")
    if not 0 < float(system.valid_fraction) < 1:
        raise ParameterError(
            f"the 'valid_fraction' parameter of {system.name} must be in (0, 1); got {system.valid_fraction!r}")
    for n in ("learning_rate", "model_fps"):
        v = getattr(system, n)
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ParameterError(f"the {n!r} parameter of {system.name} must be a positive number; got {v!r}")
    for n in ("postfilter_noise", "cca_reg"):
        v = getattr(system, n)
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
            raise ParameterError(f"the {n!r} parameter of {system.name} must be a number >= 0; got {v!r}")
    if system.uses_embedding:
        a = system.alpha_value
        if not (isinstance(a, (int, float)) and math.isfinite(a) and a >= 0):
            raise ParameterError(f"the 'alpha' parameter of {system.name} must be a number >= 0; got {system.alpha!r}")
    if system.ae_activation not in ("relu", "tanh", "sigmoid"):
        raise ParameterError(f"the 'ae_activation' parameter of {system.name} must be 'relu', 'tanh' or 'sigmoid'; "
                             f"got {system.ae_activation!r}")
    if system.feature_params is not None and not isinstance(system.feature_params, dict):
        raise ParameterError(f"feature_params must be a dict; got {type(system.feature_params).__name__}")


def check_post_params(system) -> None:
    """The post-processing chain's parameters and the synthesis seed."""
    if system.cross_fit is not None and not isinstance(system.cross_fit, (bool, np.bool_)):
        raise ParameterError(f"the 'cross_fit' parameter of {system.name} must be True, False or None (the "
                             f"system's default); got {system.cross_fit!r}")
    for n in ("variance_restore", "restore_bands", "speed_shaping", "range_limit"):
        if not isinstance(getattr(system, n), (bool, np.bool_)):
            raise ParameterError(f"the {n!r} parameter of {system.name} must be True or False; got {getattr(system, n)!r}")
    if system.speed_max_gain is not None:
        _number(system, "speed_max_gain", lambda v: math.isfinite(v) and v >= 1, "a number >= 1 or None")
    _number(system, "drift_share", lambda v: 0 <= v < 1, "a number in [0, 1)")
    _number(system, "drift_tau_s", lambda v: math.isfinite(v) and v > 0, "a positive number (s)")
    _number(system, "slow_band_gain", lambda v: math.isfinite(v) and 0 < v <= 4, "a number in (0, 4]")
    if system.idle is not None:
        _number(system, "idle", lambda v: 0 <= v <= 1, "None or a number in [0, 1]")
    if system.seed is not None:
        _pos_int(system, "seed", 0)


__all__ = ["MODEL_FPS", "DEFAULT_DRIFT_SHARE", "DEFAULT_DRIFT_TAU_S", "DEFAULT_SLOW_BAND_GAIN", "DNN_IDLE",
           "PAPER_PARAMS", "check_network_params", "check_post_params"]
