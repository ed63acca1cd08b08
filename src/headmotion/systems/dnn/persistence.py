"""The DNN systems' model files (:mod:`headmotion.models.serialization`): parameters, feature
configuration, normalisers, the post-processing tables and the networks' weights; files written
before an option load with it off (their output unchanged)."""

from __future__ import annotations

import inspect

import numpy as np

from .params import PAPER_PARAMS
from .training import clean_json


def get_state(system) -> tuple[dict, dict[str, np.ndarray]]:
    """``(config, arrays)`` of a fitted system."""
    from ...models import numpy_nets

    params = {k: (list(v) if isinstance(v, tuple) else v) for k, v in system.get_params().items()}
    config = {
        "params": params,
        "feature_config": system.feature_config_.to_dict(),
        "input_dim": system.input_dim_,
        "output_fps": system.output_fps_,
        "sample_rate": system.sample_rate_,
        "splits": system.splits_,
        "history": system.history_,
        "fit_seconds": system.fit_seconds_,
        "layers": {
            "autoencoder": None if system.autoencoder_ is None else list(system.autoencoder_.sizes),
            "regressor_input": (2 * int(system.context) + 1) * int(system.regressor_.in_dim),
            "regressor_hidden": list(system.regressor_hidden),
            "postfilter": None if system.postfilter_ is None else list(system.postfilter_.sizes),
        },
    }
    arrays: dict[str, np.ndarray] = {}
    arrays.update(system.feature_norm_.to_arrays("feature_norm"))
    arrays.update(system.motion_norm_.to_arrays("motion_norm"))
    arrays["gv"] = np.asarray(system.gv_, dtype=np.float64)
    arrays["motion_sd"] = np.asarray(system.motion_sd_, dtype=np.float64)
    for key, attr in (("band_gains", "band_gains_"), ("speed_map", "speed_map_"), ("range", "range_")):
        if getattr(system, attr, None) is not None:
            arrays[key] = np.asarray(getattr(system, attr), dtype=np.float64)
    if system.embedding_norm_ is not None:
        arrays.update(system.embedding_norm_.to_arrays("embedding_norm"))
    if system.autoencoder_ is not None:
        arrays.update(numpy_nets.state_arrays(system.autoencoder_, "autoencoder/"))
    arrays.update(numpy_nets.state_arrays(system.regressor_, "regressor/"))
    if system.postfilter_ is not None:
        arrays.update(numpy_nets.state_arrays(system.postfilter_, "postfilter/"))
    return clean_json(config), arrays


def _params(system, config) -> dict:
    """The stored parameters, with what older files lack filled as they behaved."""
    params = dict(config["params"])
    if "seed" in params:  # older files: the training seed was called seed (read so for every file)
        params["random_state"] = params.pop("seed")
    if "variance_restore" not in params:  # files written before these options: the paper's output
        params.update(PAPER_PARAMS)
    if "speed_shaping" not in params:  # files written before the band restoration and the shaper
        params.update(restore_bands=False, speed_shaping=False)
    params.setdefault("range_limit", False)  # files written before the range limit
    params.setdefault("cross_fit", False)  # files written before it: the map from the validation frames
    defaults = {k: p.default for k, p in inspect.signature(type(system).__init__).parameters.items()}
    return {k: params.get(k, defaults[k]) for k in system._param_names()}


def _networks(system, arrays) -> None:
    """The autoencoder, regressor and post-filter as numpy networks with their stored weights
    (synthesis never imports torch; shapes are checked against the settings)."""
    from ...models import numpy_nets

    system.autoencoder_, system.regressor_, system.postfilter_ = numpy_nets.load_system_nets(system, arrays)


def set_state(system, config, arrays) -> None:
    """Restore a system from ``(config, arrays)`` (:func:`get_state`'s, or an older file's)."""
    from ...features import FeatureConfig, Normalizer

    for k, v in _params(system, config).items():
        setattr(system, k, tuple(v) if k.endswith("hidden") and v is not None else v)
    system.fps_ = float(system.model_fps)
    system.sample_rate_ = int(config.get("sample_rate", 16000))
    system.feature_config_ = FeatureConfig.from_dict(config["feature_config"])
    system.input_dim_ = int(config["input_dim"])
    system.output_fps_ = float(config["output_fps"])
    system.splits_ = dict(config.get("splits") or {})
    system.history_ = config.get("history") or {}
    system.fit_seconds_ = config.get("fit_seconds")
    system.feature_norm_ = Normalizer.from_arrays(arrays, "feature_norm")
    system.motion_norm_ = Normalizer.from_arrays(arrays, "motion_norm")

    def array(key, default=None):
        return np.asarray(arrays[key], dtype=np.float64) if key in arrays else default

    system.gv_ = array("gv", np.ones(3))
    system.motion_sd_ = array("motion_sd", np.ones(3))
    system.band_gains_ = array("band_gains")
    system.speed_map_ = array("speed_map")
    system.range_ = array("range")
    system.embedding_norm_ = Normalizer.from_arrays(arrays, "embedding_norm") if system.uses_embedding else None
    _networks(system, arrays)


__all__ = ["get_state", "set_state"]
