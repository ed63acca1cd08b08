"""Template discovery (thesis §5.3) with known answers: motion built from two known templates."""

from __future__ import annotations

import numpy as np

from headmotion.motion import discovery as Dsc
from headmotion.types import Motion

FPS = 100.0


def rise(p):  # half-cosine
    return 0.5 * (1 - np.cos(np.pi * p))


def fall(p):  # fast start, slow end
    return 1 - (1 - p) ** 2


def two_template_motion(rng, seconds=40.0, jitter_deg=0.0):
    T = int(seconds * FPS)
    out = np.zeros((T, 3))
    for j in range(3):
        x, t, up = [], 0, True
        level = 0.0
        while t < T:
            n = int(rng.uniform(0.3, 0.8) * FPS)
            a = np.radians(rng.uniform(2, 6))
            p = np.arange(1, n + 1) / n
            seg = level + (a * rise(p) if up else -a * fall(p))
            x.append(seg)
            level = seg[-1]
            up = not up
            t += n
        out[:, j] = np.concatenate(x)[:T]
    # tracking jitter as video gives it: white at 25 fps, interpolated to 100 fps
    coarse = rng.standard_normal((T // 4 + 2, 3))
    tt = np.arange(T) / 4.0
    out += np.radians(jitter_deg) * np.stack([np.interp(tt, np.arange(len(coarse)), coarse[:, j]) for j in range(3)], 1)
    return Motion(out, FPS)


def test_two_known_templates_are_found(rng):
    m = two_template_motion(rng, jitter_deg=0.05)
    d = Dsc.discover([m], n_init=40, n_states=3, seed=0)
    assert d["k"] == 2
    X, lab = d["X"], d["assign"]
    ends = X[:, -1]
    # one cluster is every rising segment, the other every falling one
    for c in range(2):
        s = np.sign(ends[lab == c])
        assert abs(s.mean()) > 0.95
    p = np.linspace(0, 1, X.shape[1])
    for c in range(2):
        med = np.median(X[lab == c], axis=0)
        ref = rise(p) if med[-1] > 0 else -fall(p)
        assert np.max(np.abs(med - ref)) < 0.12
    assert min(d["sizes"]) > 0.35 * len(X)


def test_jitter_segments_are_left_out_with_min_swing(rng):
    m = two_template_motion(rng, jitter_deg=0.3)
    lit = Dsc.normalised_segments([m], min_swing_deg=0)
    clean = Dsc.normalised_segments([m], min_swing_deg=1.0)
    n_true = 3 * 40 / 0.55
    assert len(lit) > 1.3 * n_true
    assert 0.7 * n_true < len(clean) < 1.3 * n_true
    assert np.all(np.abs(clean) <= Dsc.CLIP)


def test_warping_vectors_and_bic(rng):
    m = two_template_motion(rng)
    Z = Dsc.warping_vectors([m])
    assert Z.shape[1] == 5
    assert 0.25 < np.median(Z[:, 0]) < 0.85 and np.radians(1.5) < np.median(Z[:, 1]) < np.radians(6.5)
    b = Dsc.warping_bic([m], components=(1, 2))
    assert len(b["full"]) == 2 and b["n"] == len(Z)


def test_stable_matching_is_a_permutation():
    C = np.array([[1.0, 0.0, 2.0], [0.0, 1.0, 2.0], [2.0, 2.0, 0.0]])
    assert Dsc.stable_matching(C).tolist() == [1, 0, 2]


def test_analyse_writes_figures(rng, tmp_path):
    m = two_template_motion(rng, seconds=20)
    res = Dsc.analyse([m], tmp_path, n_initialisers=(10, 20), n_sets=2, n_init_main=30, n_states=3)
    for f in ("fig5_4_stability.png", "fig5_5_intra_inter.png", "fig5_6_histograms.png", "fig5_12_bic.png",
              "discovery.json"):
        assert (tmp_path / f).stat().st_size > 0
    assert res["k_selected"] == 2
