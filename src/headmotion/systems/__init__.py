"""Synthesis systems (thesis ch. 5, paper §3) and evaluation anchors behind one interface."""

from .base import ANCHORS, SYSTEMS, MotionStream, Synthesizer, create, load_model, system_class

__all__ = ["Synthesizer", "MotionStream", "SYSTEMS", "ANCHORS", "create", "load_model", "system_class"]
