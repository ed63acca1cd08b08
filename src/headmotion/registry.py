"""The registered synthesis systems by name: a plain table (importing it loads no system), read by
:mod:`headmotion.systems.base` to create them and by :mod:`headmotion.shipped` to tell a system's
name from a model file's."""

from __future__ import annotations

#: registry name → "module:Class" (modules are imported on first use)
SYSTEMS: dict[str, str] = {
    "tws-basic": "headmotion.systems.tws.basic:TwsBasic",
    "tws-hier": "headmotion.systems.tws.hier:TwsHier",
    "le2012": "headmotion.systems.le2012:Le2012",
    "cccae": "headmotion.systems.dnn.registered:CccaeSystem",
    "ae-dnn": "headmotion.systems.dnn.registered:AeDnnSystem",
    "mfcc-dnn": "headmotion.systems.dnn.registered:MfccDnnSystem",
    "fbank-dnn": "headmotion.systems.dnn.registered:FbankDnnSystem",
    "f0e-dnn": "headmotion.systems.dnn.registered:F0eDnnSystem",
    "wav-dnn": "headmotion.systems.dnn.registered:WavDnnSystem",
    "motion-flow": "headmotion.systems.flow:MotionFlow",
    "motion-match": "headmotion.systems.motion_match:MotionMatch",
    "adapt": "headmotion.systems.adapt:Adapt",
    "loudness-wobble": "headmotion.systems.loudness_wobble:LoudnessWobble",
}


__all__ = ["SYSTEMS"]
