"""Realism in ``headmotion evaluate``, folds at pauses, leave-speakers-out, and the
default model card (``headmotion info --model default``)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from headmotion.corpus import Corpus, Recording
from headmotion.errors import ParameterError
from headmotion.evaluation.protocol import protocols as P
from headmotion.evaluation.protocol.pause_folds import choose_cuts, split_at_pauses, split_corpus_at_pauses
from headmotion.evaluation.reporting.report import realism_summary, realism_targets, render_report
from headmotion.systems.base import Synthesizer
from headmotion.types import Audio, Motion

from test_protocols import EnergyFollower, envelope, make_corpus

SR = 16000


class SeededWobble(Synthesizer):
    """A declared-range system: 2 Hz wobble of random phase per seed, clipped to ±1° ... ±3°."""

    name = "wobble"

    def __init__(self, random_state=0, stochastic="params"):
        self.random_state = random_state
        self.stochastic = stochastic

    def fit(self, corpus, *, progress=None):
        self.fps_ = float(corpus[0].motion.fps)
        self.mean_pose_ = np.zeros(3)
        self.fitted_ = True
        return self

    def reachable_range(self):
        return np.radians([[-1.0, 1.0], [-3.0, 3.0], [-3.0, 3.0]])

    def _predict(self, audio, *, seed=None):
        n = int(round(audio.duration * self.fps_))
        ph = 0.0 if self.stochastic == "none" else np.random.default_rng(seed).uniform(0, 2 * np.pi)
        t = np.arange(n) / self.fps_
        w = np.radians(2.0) * np.sin(2 * np.pi * 2.0 * t + ph)
        # pitch is clipped at its ±1° range: most frames sit at the limit
        return Motion(np.column_stack([np.clip(w, *np.radians([-1, 1])), w, 0.5 * w]), self.fps_)

    def _get_state(self):
        return {}, {}

    def _set_state(self, config, arrays):
        pass


@pytest.fixture(scope="module")
def corpus():
    return make_corpus(n_per_speaker=2, speakers=("A", "B", "C"), seconds=10.0)


@pytest.fixture(scope="module")
def res(corpus):
    return P.evaluate(corpus, [("energy", EnergyFollower), ("wobble", SeededWobble), "desync", "shifted", "still"],
                      protocol="speakers", speaker_folds=3, features=envelope, n_shifts=30, seed=1,
                      feature_sets=[], fig48=False, samples=3)


def test_realism_columns_per_recording_and_condition(res, corpus):
    # leave-speakers-out: 3 folds, each held-out speaker unseen in training
    assert res.config["folds"] == 3 and sorted(res.recordings) == sorted(corpus.ids)
    for fold, tests in res.config["fold_tests"].items():
        assert len({t[0] for t in tests}) == 1, fold
    for cond in ("ground-truth", "energy", "wobble", "desync", "still"):
        for m in ("band_1.5_4", "spectral_l1", "sd_ratio_yaw", "speed_hellinger", "accel_hellinger", "limit_cycle",
                  "drift", "bc"):
            assert len(res.values(cond, m)) == 6, (cond, m)
    # the ground truth against itself: distances 0, ratios 1
    assert np.allclose(res.values("ground-truth", "spectral_l1"), 0)
    assert np.allclose(res.values("ground-truth", "speed_hellinger"), 0)
    assert np.allclose(res.values("ground-truth", "sd_ratio_pitch"), 1)
    # a steady 2 Hz wobble: all its power in 1.5–4 Hz, a limit cycle, far from the recorded heads
    assert np.all(res.values("wobble", "band_1.5_4") > 0.95)
    assert np.all(res.values("wobble", "limit_cycle") > 0.9)
    assert res.mean("wobble", "spectral_l1") > res.mean("energy", "spectral_l1")
    # desync with no other recording of the held-out speaker = the motion circularly shifted
    assert np.allclose(res.values("desync", "sd_ratio_yaw"), 1, atol=1e-9)
    assert np.allclose(res.values("shifted", "sd_ratio_roll"), 1, atol=1e-9)
    # saturation only where the system declares its range; the clipped pitch sits at its limit
    assert len(res.values("energy", "saturation")) == 0
    assert np.all(res.values("wobble", "saturation") > 0.5)
    # diversity: 3 random phases differ; the deterministic anchors have none
    assert np.all(res.values("wobble", "diversity") > 0.3)
    assert len(res.values("still", "diversity")) == 0
    # GENEA-style pooled histograms: the shift keeps every speed but the wrap-around frame; the
    # wobble's constant-amplitude sine has a speed histogram of its own
    assert res.values("shifted", "speed_hellinger_pooled")[0] < 0.05
    assert res.values("still", "speed_hellinger_pooled")[0] > 0.9  # every frame in the lowest bin
    assert res.values("wobble", "speed_hellinger_pooled")[0] > 0.3
    # pooled coupling rows, one per condition
    p = [r for r in res.rows if r["recording"] == "ALL" and r["metric"] == "fcca_p_pooled"]
    # the floor (other speakers' recorded heads) joins every evaluation whose folds have other speakers
    assert {r["system"] for r in p} == {"ground-truth", "floor", "energy", "wobble", "desync", "shifted", "still"}
    assert res.values("energy", "fcca_p_pooled")[0] < 0.05  # it follows the speech energy
    assert res.values("wobble", "fcca_p_pooled")[0] > 0.05  # a sinusoid does not


def test_deterministic_system_gets_no_diversity(corpus):
    def fac():
        return SeededWobble(stochastic="none")
    r = P.evaluate(corpus.subset([0, 1, 2, 3]), [("wobble", fac)], protocol="speakers", features=envelope,
                   n_shifts=10, feature_sets=[], fig48=False, samples=3)
    assert len(r.values("wobble", "diversity")) == 0 and len(r.values("wobble", "limit_cycle")) == 4


def test_report_has_realism_table_targets_and_coupling(res):
    md = render_report(res)
    assert "## Realism\n" in md and "**The ruler.**" in md and "**Realism targets**" in md
    assert "issue" not in md.lower()
    assert "- **energy**: pooled FCCA excess" in md and "tied to speech across the corpus" in md
    summ = realism_summary(res)
    tg = realism_targets(summ)
    assert tg["wobble"]["band"] is False and tg["wobble"]["lc"] is False and tg["wobble"]["sat"] is False
    assert tg["energy"]["sat"] is None
    assert tg["desync"]["sd"] is True


def test_targets_measure_against_desync_when_evaluated():
    """The thesis's desync (another take of the speaker) is the ruler when present; the shift only
    without it: a candidate at speed Hellinger 0.09 is within desync 0.06 + 0.05, not shifted 0.01 + 0.05."""
    from headmotion.evaluation.reporting.report import ruler_anchor

    gt = {"speed_hellinger_pooled": 0.0}
    cand = {"speed_hellinger_pooled": 0.09}
    both = {"ground-truth": gt, "shifted": {"speed_hellinger_pooled": 0.01},
            "desync": {"speed_hellinger_pooled": 0.06}, "sys": cand}
    assert ruler_anchor(both) == "desync"
    assert realism_targets(both)["sys"]["speed"] is True
    only_shift = {k: v for k, v in both.items() if k != "desync"}
    assert ruler_anchor(only_shift) == "shifted"
    assert realism_targets(only_shift)["sys"]["speed"] is False
    assert ruler_anchor({"ground-truth": gt, "sys": cand}) is None
    assert realism_targets({"ground-truth": gt, "sys": cand})["sys"]["speed"] is None


def test_pooled_speed_histogram_over_k_samples():
    """``speed_hellinger_pooled_k`` pools all K samples: K copies of the reference score 0; a first
    sample equal to the reference with three held-still ones after it scores 0 on the first sample
    alone and, over the four, the Hellinger distance of h and 0.25 h + 0.75 δ₀ (h the reference's
    histogram, δ₀ all mass in the first bin); the targets take the K-sample value when it is there."""
    from headmotion.evaluation.measures import realism as R

    ref = Motion(np.radians(5.0) * np.column_stack([np.sin(np.arange(3000) / 13.0)] * 3), 30.0)
    still = np.zeros_like(ref.rotvec)
    rows = P.pooled_histogram_rows({"copy": {"r": ref.rotvec}, "mixed": {"r": ref.rotvec}, "anchor": {"r": still}},
                                   {"r": ref}, samples={"copy": {"r": [ref.rotvec] * 4},
                                                        "mixed": {"r": [ref.rotvec, still, still, still]}})
    v = {(r["system"], r["metric"]): r["value"] for r in rows}
    assert v[("copy", "speed_hellinger_pooled_k")] == pytest.approx(0.0, abs=1e-9)
    assert v[("mixed", "speed_hellinger_pooled")] == pytest.approx(0.0, abs=1e-9)
    sp = R.speed(ref)
    h = R.histogram(sp, R.histogram_edges(sp))
    c = 0.25 * h
    c[0] += 0.75
    assert v[("mixed", "speed_hellinger_pooled_k")] == pytest.approx(np.sqrt(1 - np.sum(np.sqrt(h * c))), abs=1e-9)
    assert v[("mixed", "speed_hellinger_pooled_k")] > 0.6
    assert ("anchor", "speed_hellinger_pooled_k") not in v
    summ = {"ground-truth": {"speed_hellinger_pooled": 0.0}, "desync": {"speed_hellinger_pooled": 0.06},
            "sys": {"speed_hellinger_pooled": 0.2, "speed_hellinger_pooled_k": 0.09}}
    assert realism_targets(summ)["sys"]["speed"] is True
    summ["sys"]["speed_hellinger_pooled_k"] = 0.12
    assert realism_targets(summ)["sys"]["speed"] is False


def test_evaluate_cli_realism_columns_and_figures(corpus, tmp_path):
    from headmotion.cli import main

    corpus.save(tmp_path / "c")
    out = tmp_path / "r"
    code = main(["evaluate", str(tmp_path / "c"), "--systems", "desync,still,shaped-noise", "-o", str(out),
                 "--shifts", "10", "--feature-table", "none", "--protocol", "speakers", "--speaker-folds", "2",
                 "--exclude", "C"])
    assert code == 0
    with open(out / "metrics.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    metrics = {r["metric"] for r in rows}
    # (the gated-noise speech of this corpus has no pause ≥ 0.5 s, so no pause_ratio here)
    assert {"band_1.5_4", "spectral_l1", "speed_hellinger", "limit_cycle", "bc",
            "fcca_p_pooled"} <= metrics
    assert not any(r["recording"].startswith("C") for r in rows)
    figs = {p.name for p in (out / "figures").iterdir()}
    assert {"realism_spectra.png", "realism_speed.png", "realism_vs_coupling.png"} <= figs
    assert main(["evaluate", str(tmp_path / "c"), "--systems", "still", "-o", str(out), "--folds-at-pauses", "1"]) != 0


def test_evaluate_cli_saves_held_out_motions(corpus, tmp_path):
    """--save-motions: one file per condition and held-out recording; the ground truth's is the
    recording's own motion, the still anchor's one pose held."""
    from headmotion.cli import main
    from headmotion.io.native import load_npz

    corpus.save(tmp_path / "c")
    out = tmp_path / "r"
    assert main(["evaluate", str(tmp_path / "c"), "--systems", "still", "-o", str(out), "--shifts", "10",
                 "--feature-table", "none", "--no-figures", "--samples", "1", "--save-motions"]) == 0
    for rec in corpus:
        gt = load_npz(out / "motions" / "ground-truth" / f"{rec.id}.npz")
        np.testing.assert_allclose(gt.rotvec, rec.motion.rotvec, atol=1e-6)
        assert gt.fps == rec.motion.fps
        still = load_npz(out / "motions" / "still" / f"{rec.id}.npz")
        assert len(still) == len(rec.motion) and np.ptp(still.rotvec, axis=0).max() < 1e-9
    assert not (tmp_path / "r2").exists()
    assert main(["evaluate", str(tmp_path / "c"), "--systems", "still", "-o", str(tmp_path / "r2"), "--shifts", "10",
                 "--feature-table", "none", "--no-figures", "--samples", "1"]) == 0
    assert not (tmp_path / "r2" / "motions").exists()


# -- folds at pauses ----------------------------------------------------------------------------------
def planted_take(rng, bursts, sr=SR, fps=30.0):
    """Speech-like bursts (a 150 Hz buzz with a 4 Hz syllable envelope) separated by silences;
    ``bursts`` = [(speech s, silence s), …].  Returns the recording and the silence intervals (s)."""
    parts, sil, t = [], [], 0.0
    for sp, si in bursts:
        n = int(sp * sr)
        tt = np.arange(n) / sr
        parts.append(0.3 * np.sin(2 * np.pi * 150 * tt) * (0.6 + 0.4 * np.sin(2 * np.pi * 4 * tt)))
        t += sp
        m = int(si * sr)
        parts.append(1e-4 * rng.standard_normal(m))
        sil.append((t, t + si))
        t += si
    audio = Audio(np.concatenate(parts).astype(np.float32), sr)
    T = int(round(audio.duration * fps))
    motion = Motion(np.radians(2) * np.column_stack([np.sin(np.arange(T) / 17.0)] * 3), fps)
    return Recording.aligned("take", "actor", "mocap", audio, motion), sil[:-1]


def test_folds_at_pauses_split_a_planted_take_at_its_silences(rng):
    bursts = [(7.0, 0.8), (5.0, 0.25), (6.0, 1.0), (8.0, 0.6), (6.5, 0.7), (7.0, 0.5)]
    rec, silences = planted_take(rng, bursts)
    long_sil = [(a, b) for a, b in silences if b - a >= 0.3]
    for n in (3, 4, 5):
        parts = split_at_pauses(rec, n, min_fold_s=5.0)
        assert len(parts) == n
        assert [p.id for p in parts] == [f"take_p{i}" for i in range(n)]
        assert sum(len(p.motion) for p in parts) == len(rec.motion)
        t = 0.0
        for p in parts[:-1]:
            t += len(p.motion) / rec.motion.fps
            # every cut lies inside a silence of ≥ 0.3 s (never in the 0.25 s one, never in speech)
            assert any(a < t < b for a, b in long_sil), (n, t)
        assert all(p.duration >= 5.0 - 0.05 for p in parts)
    c, warns = split_corpus_at_pauses(Corpus([rec], sample_rate=SR), 6)
    assert len(c) <= 6 and (len(c) == 6 or warns)
    with pytest.raises(ParameterError, match="no pause"):
        split_at_pauses(planted_take(rng, [(8.0, 0.1), (8.0, 0.1)])[0], 3)


def test_choose_cuts_known_answer():
    # candidates at 10, 50, 95 s of a 100 s take (1 fps): 2 folds → the middle one
    assert choose_cuts([10, 50, 95], 100, 2, fps=1.0, min_fold_s=5.0) == [0, 50, 100]
    # 3 folds: cut 1 → 50 (nearest 33); no candidate leaves 6 s after 50 and before the end → 2 folds
    assert choose_cuts([10, 50, 95], 100, 3, fps=1.0, min_fold_s=6.0) == [0, 50, 100]
    assert choose_cuts([10, 50, 95], 100, 3, fps=1.0, min_fold_s=4.0) == [0, 50, 95, 100]
    with pytest.raises(ParameterError):
        choose_cuts([10], 100, 1, fps=1.0)


# -- the default model card ---------------------------------------------------------------------------
def test_info_model_default_prints_the_card(capsys):
    from headmotion.cli import main

    assert main(["info", "--model", "default"]) == 0
    out = capsys.readouterr().out
    assert "Model card" in out and "licence" in out.lower()
    assert "mead_lrs3" in out  # says it was left out, and why


def test_systems_declare_their_reachable_range():
    """tws-* and le2012 declare their clip (training range ± 10 %); the DNN systems none."""
    from headmotion.synthetic import planted_corpus
    from headmotion.systems import create

    c = planted_corpus(minutes=1.0, n_recordings=3, fps=50.0, seed=2)
    allr = np.vstack([r.motion.rotvec for r in c])
    lo, hi = allr.min(0), allr.max(0)
    for name in ("tws-basic", "le2012"):
        m = create(name).fit(c)
        r = m.reachable_range()
        assert r.shape == (3, 2), name
        np.testing.assert_allclose(r[:, 1] - r[:, 0], 1.2 * (hi - lo), rtol=0.05, err_msg=name)
    assert Synthesizer.reachable_range(create("tws-basic")) is None  # the contract's default


def test_info_model_stream_prints_its_card(capsys):
    from headmotion.cli import main

    from headmotion.synthesis import load_model

    assert main(["info", "--model", "stream"]) == 0
    out = capsys.readouterr().out
    # the card names the system the shipped file really holds, whichever it is
    assert "Model card" in out and f"`{load_model('stream').name}`" in out
    assert main(["info", "--model", "/nonexistent/model.hmz"]) != 0


def test_pause_ratio_over_k_samples():
    """``pause_ratio_k`` pools the pause and speech speeds of all K samples: K copies give the one
    motion's ratio; a sample still in its pauses (ratio 0) and one moving in its pauses at the
    speech speed (ratio 1), with equal speeds in speech, pool to 1/2 exactly; without samples it
    is left out; the pause target takes the K-sample value when it is there."""
    from headmotion.evaluation.measures import realism as R

    fps, n = 25.0, 500
    mask = np.ones(n, bool)
    mask[200:300] = False                       # a 4-s pause
    t = np.arange(n)[:, None] * np.ones(3)
    moving = np.radians(0.5) * t                # constant speed everywhere: ratio 1
    settled = moving.copy()
    settled[200:300] = settled[199]             # still in the pause: ratio 0
    settled[300:] = settled[199] + np.radians(0.5) * (t[300:] - 199)   # same speed again after it
    ref = Motion(moving, fps)
    one = R.realism(ref, Motion(moving, fps), speech_mask=mask, samples=[moving] * 4)
    assert one["pause_ratio_k"] == pytest.approx(one["pause_ratio"]) == pytest.approx(1.0, abs=0.02)
    mixed = R.realism(ref, Motion(settled, fps), speech_mask=mask, samples=[settled, moving])
    assert mixed["pause_ratio"] == pytest.approx(0.0, abs=1e-9)
    assert mixed["pause_ratio_k"] == pytest.approx(0.5, abs=0.02)
    assert np.isnan(R.realism(ref, Motion(settled, fps), speech_mask=mask)["pause_ratio_k"])
    summ = {"ground-truth": {"pause_ratio": 0.4}, "sys": {"pause_ratio": 0.7, "pause_ratio_k": 0.45}}
    assert realism_targets(summ)["sys"]["pause"] is True
    summ["sys"]["pause_ratio_k"] = 0.6
    assert realism_targets(summ)["sys"]["pause"] is False
    del summ["sys"]["pause_ratio_k"]
    assert realism_targets(summ)["sys"]["pause"] is False      # the one motion's 0.7
