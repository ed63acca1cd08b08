"""Templates and encoding (thesis §5.1, §5.3 eq 5.1–5.2, Table 5.1)."""

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.motion.templates import (corpus_encoding_errors, decode, encode, encode_axis, encoding_errors, g1,
                                         g2, render)
from headmotion.types import Motion


def test_equations_5_1_and_5_2():
    t = np.linspace(0, 10, 11)
    up = g1(t, d=10, a=2.0, c=1.0)
    down = g2(t, d=10, a=2.0, c=1.0)
    assert up[0] == pytest.approx(1.0) and up[-1] == pytest.approx(3.0)
    assert down[0] == pytest.approx(1.0) and down[-1] == pytest.approx(-1.0)
    # the shared signed-amplitude form
    np.testing.assert_allclose(render(1.0, [10], [2.0]), up, atol=1e-12)
    np.testing.assert_allclose(render(1.0, [10], [-2.0]), down, atol=1e-12)


def test_sum_of_cosines_round_trip_within_stated_rms():
    """segment -> encode -> decode reproduces a sum of cosines: RMS error < 10 % of its RMS amplitude (thesis Table 5.1: 0.101 vs 0.205)."""
    fps = 100.0
    t = np.arange(3000) / fps
    x = 0.05 * np.cos(2 * np.pi * 0.7 * t) + 0.02 * np.cos(2 * np.pi * 1.9 * t + 1.0)
    e = encode_axis(x, fps=fps)
    y = decode([e], n_frames=len(x))[:, 0]
    rms = np.sqrt(np.mean((y - x) ** 2))
    assert rms < 0.10 * np.sqrt(np.mean((x - x.mean()) ** 2))
    errs = encoding_errors(x, fps=fps)
    assert errs["cosine"] < errs["linear"]  # Table 5.1: cosine templates encode better


def test_single_cosine_is_nearly_exact():
    fps = 100.0
    t = np.arange(2000) / fps
    x = 0.1 * np.cos(2 * np.pi * 0.5 * t)
    y = decode(encode(x[:, None], fps=fps), n_frames=len(x))[:, 0]
    assert np.sqrt(np.mean((y - x) ** 2)) < 1e-3


def test_continuity_and_alternation():
    rng = np.random.default_rng(1)
    x = np.cumsum(rng.normal(size=2000)) * 0.002
    e = encode_axis(x, fps=100)
    y = decode([e])[:, 0]
    assert np.max(np.abs(np.diff(y))) < 0.05
    np.testing.assert_allclose(e.offsets[1:], e.start + np.cumsum(e.amplitudes)[:-1])


def test_corpus_errors_pool_axes():
    fps = 100.0
    t = np.arange(1500) / fps
    rv = np.stack([0.05 * np.cos(2 * np.pi * f * t) for f in (0.6, 0.9, 1.3)], 1)
    res = corpus_encoding_errors([Motion(rv, fps)], by_axis=True)
    assert res["frames"] == rv.size
    assert res["cosine"] < 0.01 * 5 and res["rms_amplitude"] == pytest.approx(0.05 / np.sqrt(2), rel=0.02)
    assert set(res["axes"]) == {"rx", "ry", "rz"}


def test_bad_template_arguments():
    with pytest.raises(ParameterError, match="positive"):
        render(0.0, [0.0], [1.0])
    with pytest.raises(ParameterError, match="template kind"):
        render(0.0, [5.0], [1.0], kind="spline")
