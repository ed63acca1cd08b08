"""The frequency bands of head motion shared by the realism measure
(:mod:`headmotion.evaluation.measures.realism`), the band restoration of the post-processing chain
(:mod:`headmotion.motion.post.restore`) and style transfer (:mod:`headmotion.motion.style`):
below 0.5 Hz posture shifts, 0.5–1.5 Hz phrase-level nods, 1.5–4 Hz syllable-rate bobbing, above
4 Hz jitter."""

#: crossover frequencies (Hz) between the bands, low to high
BAND_EDGES_HZ = (0.5, 1.5, 4.0)


def band_names(top: float | None = None, edges=BAND_EDGES_HZ) -> tuple[str, ...]:
    """The bands' names, one spelling everywhere: ``"LOW_HIGH"`` in Hz (``"0_0.5"``, ``"0.5_1.5"``,
    ``"1.5_4"``); the top band ends at ``top`` (``"4_10"``) or, without one, is open (``"4_up"``)."""
    lows, highs = (0.0, *edges), (*edges, top)
    return tuple(f"{lo:g}_{'up' if hi is None else format(hi, 'g')}" for lo, hi in zip(lows, highs))


__all__ = ["BAND_EDGES_HZ", "band_names"]
