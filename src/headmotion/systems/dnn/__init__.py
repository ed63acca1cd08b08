"""The paper's system and its baselines (paper §3–4: CCCAE waveform embedding → DNN regressor →
post-filter) as :class:`~headmotion.systems.base.Synthesizer` s.

=================  =====================  ==============================================================
registry name      class                  pipeline
=================  =====================  ==============================================================
``cccae``          :class:`CccaeSystem`   wav frames → CCCAE (α = 1) embedding → regressor → post-filter
``ae-dnn``         :class:`AeDnnSystem`   wav frames → plain autoencoder (α = 0) → regressor → post-filter
``mfcc-dnn``       :class:`MfccDnnSystem` MFCC-39 → regressor → post-filter          (M_MFCC)
``fbank-dnn``      :class:`FbankDnnSystem` FBank-27 → regressor → post-filter
``f0e-dnn``        :class:`F0eDnnSystem`  F0 + energy (+Δ, ΔΔ) → regressor → post-filter
``wav-dnn``        :class:`WavDnnSystem`  raw 100-dim waveform frames → regressor → post-filter
=================  =====================  ==============================================================

Every system uses the same regressor (paper §3.2, §4.2); only the input differs.  The networks
and their training loops are in :mod:`headmotion.models.nets`, the CCA term in
:mod:`headmotion.models.dcca`.  The model works at 100 frames/s, the paper's rate, whatever the
corpus's: the training motion is resampled to it, so the ±25-frame context covers 510 ms and the
post-filter's segments 0.5 s; ``predict`` gives motion at that rate (the caller resamples).

Data use (paper §4.1–4.2): :func:`headmotion.corpus.paper_split` assigns recordings to train /
valid / test per speaker; validation recordings only stop training early; a speaker without one
has the last ``valid_fraction`` of every training recording held out; training uses the speaking
frames only.  ``fit`` seeds torch with ``random_state`` and switches on its deterministic
algorithms, so the same seed and thread count (``n_threads``, default one) give the same model.

After the networks, synthesis runs the post-processing chain of :mod:`headmotion.motion.post`
(not in the paper; ``docs/decisions/post-chain.md``), in this order, each stage a parameter:
variance or per-band restoration about the running mean with posture drift (``variance_restore``,
``restore_bands``, ``slow_band_gain``, ``drift_share``, ``drift_tau_s``; ``seed`` seeds the
drift), speed shaping (``speed_shaping``; the map cross-fitted with ``cross_fit``, bounded by
``speed_max_gain``; ``docs/decisions/cross-fitting.md``, ``speed-shaping.md``), the soft range
limit (``range_limit``) and pause settling (``idle``).  :data:`PAPER_PARAMS` switches every stage
off: the paper's output, deterministic.  Model files written before a stage existed load with it off.

Streaming (:mod:`.streaming`): ``stream()`` works with the lookahead the regressor's context and
the post-filter's segments need (``latency_ms``: 797.5 ms for mfcc-dnn) and equals ``predict``.
``predict_features(track)`` runs the model on an extracted feature track; ``embed(audio)`` (CCCAE /
AE systems) returns the learned embedding (paper Table 1).

Modules: :mod:`.params` (defaults, checks), :mod:`.data` (training data), :mod:`.training` (the
networks), :mod:`.calibration` (the chain's tables), :mod:`.inference` (every network forward at
synthesis), :mod:`.synthesis` (the chain), :mod:`.streaming`, :mod:`.persistence`,
:mod:`.system` (the shared class), :mod:`.registered` (the systems).

Libraries considered: PyTorch for the networks; scikit-learn's ``MLPRegressor`` has no custom loss
or layer-wise pre-training.
"""

from .params import DEFAULT_DRIFT_SHARE, DEFAULT_DRIFT_TAU_S, DEFAULT_SLOW_BAND_GAIN, DNN_IDLE, MODEL_FPS, PAPER_PARAMS
from .registered import AeDnnSystem, CccaeSystem, F0eDnnSystem, FbankDnnSystem, MfccDnnSystem, WavDnnSystem
from .system import DnnSystem

__all__ = ["CccaeSystem", "AeDnnSystem", "MfccDnnSystem", "FbankDnnSystem", "F0eDnnSystem", "WavDnnSystem",
           "DnnSystem", "MODEL_FPS", "PAPER_PARAMS", "DEFAULT_DRIFT_SHARE", "DEFAULT_DRIFT_TAU_S",
           "DEFAULT_SLOW_BAND_GAIN", "DNN_IDLE"]
