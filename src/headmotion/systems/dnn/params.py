"""The DNN systems' product defaults and the checks of their parameters."""

from __future__ import annotations

import math

from ...errors import ParameterError
from ..constraints import BOOLEAN, SIZES, Options, check_params, real, whole

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


#: what each network and training parameter may be (:mod:`..constraints`)
NETWORK_CONSTRAINTS = {
    **{n: [whole(1)] for n in ("embedding_dim", "batch_size", "max_epochs", "ae_max_epochs", "patience",
                               "postfilter_code")},
    **{n: [whole(0)] for n in ("context", "pretrain_epochs", "random_state")},
    "segment": [whole(2)], "cca_batch_size": [whole(2)],
    **{n: [SIZES] for n in ("ae_hidden", "regressor_hidden", "postfilter_hidden")},
    "n_threads": [whole(1), None],
    "dropout": [real(0, 1, closed="left")], "valid_fraction": [real(0, 1, closed="neither")],
    "learning_rate": [real(0, closed="neither")], "model_fps": [real(0, closed="neither")],
    "postfilter_noise": [real(0)], "cca_reg": [real(0)],
    "ae_activation": [Options(("relu", "tanh", "sigmoid"))],
    "batch_scale": [whole(1)], "precision": [Options(("float32", "bf16"))], "compile_networks": [BOOLEAN],
}
#: what each post-processing parameter and the synthesis seed may be
POST_CONSTRAINTS = {
    "cross_fit": [BOOLEAN, None],
    **{n: [BOOLEAN] for n in ("variance_restore", "restore_bands", "speed_shaping", "range_limit")},
    "speed_max_gain": [real(1), None], "drift_share": [real(0, 1, closed="left")],
    "drift_tau_s": [real(0, closed="neither")], "slow_band_gain": [real(0, 4, closed="right")],
    "idle": [real(0, 1), None], "seed": [whole(0), None],
}


def check_network_params(system) -> None:
    """The networks' and training's parameters (sizes, epochs, rates)."""
    if system.alpha_fixed and system.alpha not in (None, system.default_alpha):
        raise ParameterError(
            f"{system.name} is the autoencoder with alpha = {system.default_alpha:g}; use the 'cccae' system for "
            f"another alpha (got {system.alpha!r})")
    check_params(system, NETWORK_CONSTRAINTS)
    if system.uses_embedding:
        a = system.alpha_value
        if not (isinstance(a, (int, float)) and math.isfinite(a) and a >= 0):
            raise ParameterError(f"the 'alpha' parameter of {system.name} must be a number >= 0; got {system.alpha!r}")
    if system.feature_params is not None and not isinstance(system.feature_params, dict):
        raise ParameterError(f"the 'feature_params' parameter of {system.name} must be a dict or None; "
                             f"got {type(system.feature_params).__name__}")


def check_post_params(system) -> None:
    """The post-processing chain's parameters and the synthesis seed."""
    check_params(system, POST_CONSTRAINTS)


__all__ = ["MODEL_FPS", "DEFAULT_DRIFT_SHARE", "DEFAULT_DRIFT_TAU_S", "DEFAULT_SLOW_BAND_GAIN", "DNN_IDLE",
           "PAPER_PARAMS", "NETWORK_CONSTRAINTS", "POST_CONSTRAINTS", "check_network_params", "check_post_params"]
