"""Synthesis systems (thesis ch. 5, paper §3) behind one contract (:mod:`.base`); the evaluation
anchors are in :mod:`headmotion.evaluation.protocol.anchors`."""

from .base import (CAUSAL, EMBEDDING, NEEDS_OTHER_SPEAKERS, STOCHASTIC, STREAMING, SYSTEMS, MotionStream, Synthesizer,
                   create, load_model, system_class)

__all__ = ["Synthesizer", "MotionStream", "SYSTEMS", "create", "load_model", "system_class", "CAUSAL", "EMBEDDING",
           "NEEDS_OTHER_SPEAKERS", "STREAMING", "STOCHASTIC"]
