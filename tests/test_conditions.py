"""Evaluation conditions behind one contract: anchors, trained systems and model files
(headmotion.evaluation.protocol.conditions, .condition_specs)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from headmotion.errors import ModelFileError, ParameterError
from headmotion.evaluation.protocol import protocols as P
from headmotion.evaluation.protocol.anchors import ANCHORS, create_anchor
from headmotion.evaluation.protocol.condition_specs import SHIPPED_MODELS, condition_spec, shipped_model_path
from headmotion.evaluation.protocol.conditions import Condition, ModelFileCondition, SystemCondition
from headmotion.evaluation.protocol.parallel import sub_seed
from headmotion.evaluation.protocol.scoring import conform
from headmotion.systems.base import load_model

from test_protocols import EnergyFollower, envelope, make_corpus

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def small():
    return make_corpus(n_per_speaker=2, speakers=("A",), seconds=8.0)


def test_every_anchor_is_a_condition(small):
    for name in ANCHORS:
        a = create_anchor(name)
        assert isinstance(a, Condition) and a.name == name
        assert not a.sampled and a.reachable_range() is None and not a.embedding
    assert [n for n in ANCHORS if create_anchor(n).reference] == ["ground-truth"]
    gt = create_anchor("ground-truth").fit(small)
    np.testing.assert_array_equal(gt.motion_for(small[1], seed=3).rotvec, small[1].motion.rotvec)


def test_a_system_condition_is_its_predict(small):
    c = SystemCondition("ef", EnergyFollower, random_state=7)
    assert c.model.random_state == 7 and c.sampled and not c.needs_other_speakers
    c.fit(small)
    np.testing.assert_array_equal(c.motion_for(small[0], seed=5).rotvec, c.model.predict(small[0].audio, seed=5).rotvec)


def test_names_resolve_to_conditions(tmp_path):
    assert condition_spec("desync").kind == "anchor"
    assert condition_spec("tws-hier").kind == "system"
    spec = condition_spec("le2012[idle=0.5]")
    assert (spec.kind, spec.name, spec.seed_name) == ("system", "le2012[idle=0.5]", "le2012")
    for name, file in SHIPPED_MODELS.items():
        spec = condition_spec(name)
        assert (spec.kind, spec.name, Path(spec.target).name) == ("model", name, file)
        assert Path(spec.target) == shipped_model_path(name) and Path(spec.target).is_file()
    with pytest.raises(ParameterError, match=r"unknown system 'nonsense'.*shipped model \(default, stream\)"):
        condition_spec("nonsense")
    with pytest.raises(ParameterError, match="model file .*nope.hmz not found"):
        condition_spec(str(tmp_path / "nope.hmz"))
    bad = tmp_path / "bad.hmz"
    bad.write_bytes(b"not a model")
    with pytest.raises(ModelFileError, match="bad.hmz"):
        condition_spec(str(bad))


def test_a_model_file_is_scored_as_it_is_on_every_recording(small, tmp_path):
    """Known answer: the motion evaluated for a model file is exactly ``load_model(path).predict``
    with the recording's seed, in every fold (no retraining)."""
    mine = tmp_path / "mine.hmz"
    shutil.copy(shipped_model_path("stream"), mine)
    res = P.evaluate(small, ["stream", str(mine), "desync"], features=envelope, n_shifts=10, feature_sets=[],
                     fig48=False, samples=2)
    assert res.systems == ["ground-truth", "stream", str(mine), "desync"]
    assert res.config["folds"] == 2 and not res.warnings
    model = load_model(mine)
    for name in ("stream", str(mine)):
        assert sorted(res.motions[name]) == ["A0", "A1"]
        for rec in small:
            want = conform(model.predict(rec.audio, seed=sub_seed(0, rec.id, name)), rec.motion, name, rec.id)
            np.testing.assert_array_equal(res.motions[name][rec.id], want.astype(np.float32))
        assert len(res.values(name, "fcca")) == 2
        assert np.isfinite(res.mean(name, "diversity"))  # a stochastic model: K samples per recording
    rec = small[[r.id for r in small].index(res.trajectory_recording)]
    want = model.predict(rec.audio, seed=sub_seed(0, rec.id, "stream"))
    np.testing.assert_array_equal(res.trajectories["stream"], conform(want, rec.motion, "stream", rec.id))
    assert isinstance(condition_spec(str(mine)).make(), ModelFileCondition)


def test_cli_scores_a_model_file_beside_anchors(small, tmp_path):
    small.save(tmp_path / "c")
    shutil.copy(shipped_model_path("stream"), tmp_path / "mine.hmz")
    cmd = [sys.executable, "-m", "headmotion", "evaluate", str(tmp_path / "c"), "--systems", "mine.hmz,desync",
           "--shifts", "10", "--samples", "1", "--feature-table", "none", "--no-figures", "-o", str(tmp_path / "r")]
    env = {"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin", "NO_COLOR": "1", "COLUMNS": "120"}
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    text = (tmp_path / "r" / "metrics.csv").read_text()
    assert "\nmine.hmz,A0,fcca," in text and "\nmine.hmz,A1,nmse," in text
    report = (tmp_path / "r" / "report.md").read_text()
    assert "Realism targets" in report and "issue" not in report.lower()
    missing = subprocess.run(cmd[:6] + ["gone.hmz"] + cmd[7:], capture_output=True, text=True, cwd=tmp_path,
                             env=env, timeout=120)
    assert missing.returncode != 0 and "gone.hmz not found" in missing.stderr
    assert "Traceback" not in missing.stderr


def test_a_new_measure_plugs_in_per_recording_and_pooled(small, monkeypatch):
    """A measure appended to the scoring tuples lands in the rows of every condition."""
    from headmotion.evaluation.protocol import scoring as S

    def frames(s):
        return {"frames": float(len(s.pred))}

    def seed_seen(p):
        return [{"system": c, "recording": "ALL", "metric": "seed_seen", "value": float(p.seed)}
                for c in p.conditions if p.options.get("on", True)]

    monkeypatch.setattr(S, "RECORDING_MEASURES", S.RECORDING_MEASURES + (S.Measure("frames", frames),))
    monkeypatch.setattr(S, "POOLED_MEASURES", S.POOLED_MEASURES + (S.PooledMeasure("seed seen", seed_seen),))
    res = P.evaluate(small, ["still", "shifted"], features=envelope, n_shifts=10, feature_sets=[], fig48=False,
                     seed=5)
    for c in res.systems:
        assert list(res.values(c, "frames")) == [float(len(r.motion)) for r in small]
        assert list(res.values(c, "seed_seen")) == [5.0]
    assert "seed seen" in res.timings
