"""Systems with parameters on the command line and in ``evaluate`` (headmotion.systems.spec)."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.evaluation.protocol import protocols as P
from headmotion.systems.spec import SystemFactory, label, parse_system, split_systems

from test_protocols import make_corpus


def test_split_keeps_brackets_together():
    assert split_systems("a, b[x=1;y=2] ,c") == ["a", "b[x=1;y=2]", "c"]
    assert split_systems("le2012[idle=0.5,post_restore=false],still") == ["le2012[idle=0.5,post_restore=false]", "still"]
    assert split_systems("mfcc-dnn[regressor_hidden=[64,64]]") == ["mfcc-dnn[regressor_hidden=[64,64]]"]
    for bad in ("a[x=1", "a]x", "a[[x=1]"):
        with pytest.raises(ParameterError, match="unbalanced"):
            split_systems(bad)


def test_parse_reads_json_values_and_text():
    assert parse_system("le2012") == ("le2012", {})
    name, p = parse_system("le2012[idle=0.5; post_restore=false, features=f0e]")
    assert name == "le2012" and p == {"idle": 0.5, "post_restore": False, "features": "f0e"}
    assert parse_system("mfcc-dnn[regressor_hidden=[64,64];idle=null]")[1] == {"regressor_hidden": [64, 64],
                                                                                "idle": None}
    assert parse_system('mfcc-dnn[feature_params={"deltas":false,"n_ceps":8},context=5]')[1] == {
        "feature_params": {"deltas": False, "n_ceps": 8}, "context": 5}
    assert label(*parse_system("le2012[post_restore=false;idle=0.5]")) == "le2012[idle=0.5;post_restore=false]"


def test_parse_refuses_what_the_system_does_not_have():
    with pytest.raises(ParameterError, match=r"le2012 has no parameter 'nope'.*its parameters are"):
        parse_system("le2012[nope=1]")
    with pytest.raises(ParameterError, match=r"'le2012\[idle=2\]'.*'idle' parameter of le2012 must be"):
        parse_system("le2012[idle=2]")
    with pytest.raises(ParameterError, match="unknown system 'nonsense'"):
        parse_system("nonsense[x=1]")
    with pytest.raises(ParameterError, match="KEY=VALUE"):
        parse_system("le2012[idle]")
    with pytest.raises(ParameterError, match="NAME or NAME"):
        parse_system("le 2012")


def test_factory_builds_the_system_and_pickles():
    import pickle

    f = pickle.loads(pickle.dumps(SystemFactory("le2012", {"idle": 0.3})))
    m = f()
    assert m.name == "le2012" and m.idle == 0.3


@pytest.fixture(scope="module")
def corpus():
    return make_corpus(n_per_speaker=2, seconds=10.0)


def _values(res, system):
    return {(r["recording"], r["metric"]): r["value"] for r in res.rows if r["system"] == system}


def test_evaluate_pairs_a_setting_with_its_plain_system(corpus):
    # random_state is overridden by the fold's training seed, so "le2012[random_state=7]" is the
    # plain system: with paired seeds every score must be identical; idle=null must change the motion
    res = P.evaluate(corpus, ["le2012", "le2012[random_state=7]", "le2012[idle=null]"], protocol="loo",
                     features="f0e", n_shifts=10, feature_sets=[], samples=2, fig48=False)
    assert set(res.systems) >= {"le2012", "le2012[random_state=7]", "le2012[idle=null]"}
    a, b, c = (_values(res, s) for s in ("le2012", "le2012[random_state=7]", "le2012[idle=null]"))
    assert a and a.keys() == b.keys()
    for k in a:
        assert a[k] == b[k] or (np.isnan(a[k]) and np.isnan(b[k])), k
    assert any(a[k] != c.get(k) for k in a if not np.isnan(a[k]))


def test_train_cli_takes_parameters(corpus, tmp_path):
    from headmotion.cli import main
    from headmotion.systems import load_model

    corpus.save(tmp_path / "c")
    out = tmp_path / "m.hmz"
    assert main(["train", str(tmp_path / "c"), "--system", "le2012[idle=0.3;post_restore=false]", "-o", str(out)]) == 0
    m = load_model(out)
    assert m.idle == 0.3 and m.post_restore is False
    assert main(["train", str(tmp_path / "c"), "--system", "le2012[nope=1]", "-o", str(tmp_path / "x.hmz")]) != 0
    assert not (tmp_path / "x.hmz").exists()
