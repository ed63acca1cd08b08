"""The frequency bands of head motion shared by the realism measure
(:mod:`headmotion.evaluation.measures.realism`), the band restoration of the post-processing chain
(:mod:`headmotion.motion.post.restore`) and style transfer (:mod:`headmotion.motion.style`):
below 0.5 Hz posture shifts, 0.5–1.5 Hz phrase-level nods, 1.5–4 Hz syllable-rate bobbing, above
4 Hz jitter."""

#: crossover frequencies (Hz) between the bands, low to high
BAND_EDGES_HZ = (0.5, 1.5, 4.0)

__all__ = ["BAND_EDGES_HZ"]
