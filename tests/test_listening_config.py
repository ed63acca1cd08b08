"""Listening-test configuration and trial plans: clear errors naming the line; seeded,
reproducible per-participant order; training first; balanced A/B sides (thesis §4.2.3, §5.5.1)."""

from __future__ import annotations

import shutil
from collections import Counter
from pathlib import Path

import pytest

from headmotion.errors import FormatError
from headmotion.listening.config import load_config
from headmotion.listening.plan import blind_id, make_plan, public_trial, unblind_id


@pytest.fixture
def test_dir(tmp_path, examples_dir) -> Path:
    d = tmp_path / "t"
    shutil.copytree(examples_dir / "listening", d, ignore=shutil.ignore_patterns("results"))
    return d


def _write(d: Path, text: str) -> Path:
    p = d / "bad.yaml"
    p.write_text(text)
    return p


GOOD = """type: mos_ref
items:
  - id: s1
    speaker: A
    reference: {motion: motion/s1_natural.npz, audio: audio/s1.wav}
    conditions:
      natural: {motion: motion/s1_natural.npz, audio: audio/s1.wav}
      noise: {motion: motion/s1_noise.npz, audio: audio/s1.wav}
"""


def test_examples_load(examples_dir):
    for name, kind, n in (("config.yaml", "mos_ref", 19), ("mushra.yaml", "mushra", 4),
                          ("ab.yaml", "ab", 12)):
        cfg = load_config(examples_dir / "listening" / name)
        assert cfg.type == kind
        assert cfg.n_trials == n
        assert len(make_plan(cfg, 1)) == n


def test_minimal_config(test_dir):
    cfg = load_config(_write(test_dir, GOOD))
    assert cfg.question == "How similar is the video on the right to the video on the left?"
    assert cfg.scale_points == 7
    assert [s.kind for s in cfg.stimuli.values()] == ["motion"] * 2  # reference == natural


@pytest.mark.parametrize("text, line, match", [
    ("type: mos_ref\nitems: [\n  - id: x\n", 3, "invalid YAML"),
    (GOOD.replace("type: mos_ref", "type: mos"), 1, "'type' must be one of"),
    (GOOD + "colour: blue\n", 9, "unknown key 'colour'"),
    (GOOD.replace("s1_noise.npz", "missing.npz"), 8, "does not exist"),
    (GOOD.replace("motion/s1_noise.npz", "../../etc/passwd.npz"), 8, "leaves the test folder"),
    (GOOD.replace("motion/s1_noise.npz", "/etc/x.npz"), 8, "must be a path relative"),
    (GOOD.replace("    reference: {motion: motion/s1_natural.npz, audio: audio/s1.wav}\n", ""),
     3, "needs a 'reference'"),
    (GOOD.replace("audio/s1.wav}\n    conditions", "audio/s1.txt}\n    conditions"), 5,
     "unsupported extension"),
    (GOOD + "seed: -3\n", 9, r"'seed' must be an integer in the range"),
    (GOOD + "scale: {points: 5, labels: [a, b]}\n", 9, "one label per point"),
    (GOOD + "attention_checks:\n  - {after: 1, question: q, options: [a, b], answer: c}\n", 10,
     "not one of the options"),
    (GOOD.replace("noise: {", "natural: {"), 8, "duplicate key 'natural'"),
    (GOOD + "demographics:\n  - name: age\n    type: choice\n", 10, "needs 'options'"),
])
def test_bad_config_names_the_line(test_dir, text, line, match):
    p = _write(test_dir, text)
    with pytest.raises(FormatError, match=match) as ei:
        load_config(p)
    assert ei.value.line == line, str(ei.value)
    assert f"bad.yaml, line {line}:" in str(ei.value)


def test_mushra_needs_hidden_reference_and_anchor(test_dir):
    text = GOOD.replace("type: mos_ref", "type: mushra\nmushra: {anchor: noise}")
    with pytest.raises(FormatError, match="hidden reference as condition 'reference'") as ei:
        load_config(_write(test_dir, text))
    assert ei.value.line == 8
    text = text.replace("natural: {", "reference: {").replace("anchor: noise", "anchor: lowpass")
    with pytest.raises(FormatError, match="anchor condition 'lowpass'"):
        load_config(_write(test_dir, text))


def test_missing_and_empty_files(tmp_path):
    with pytest.raises(FormatError, match="does not exist"):
        load_config(tmp_path / "nope.yaml")
    (tmp_path / "e.yaml").write_text("")
    with pytest.raises(FormatError, match="empty"):
        load_config(tmp_path / "e.yaml")


def test_plan_is_seeded_and_differs_between_participants(examples_dir):
    cfg = load_config(examples_dir / "listening" / "config.yaml")
    a1, a2, b = make_plan(cfg, 1), make_plan(cfg, 1), make_plan(cfg, 2)
    assert a1 == a2
    key = [(t["item"], t.get("slots", [{}])[0].get("condition")) for t in a1]
    assert key != [(t["item"], t.get("slots", [{}])[0].get("condition")) for t in b]
    # training first, flagged; every (item, condition) exactly once; attention after 8 test trials
    assert [t["phase"] for t in a1[:2]] == ["training", "training"]
    assert a1[2 + 8]["kind"] == "attention"
    test = Counter((t["item"], t["slots"][0]["condition"]) for t in a1 if t["phase"] == "test")
    assert len(test) == 16 and set(test.values()) == {1}


def test_ab_sides_balanced_within_and_across_participants(test_dir):
    # an odd number of trials per pair: balanced over pairs of participants
    text = """type: ab
items:
""" + "".join(f"""  - id: s{k}
    conditions:
      x: {{motion: motion/s1_natural.npz, audio: audio/s1.wav}}
      y: {{motion: motion/s1_noise.npz, audio: audio/s1.wav}}
      z: {{motion: motion/s1_system.npz, audio: audio/s1.wav}}
""" for k in range(5))
    cfg = load_config(_write(test_dir, text))
    total = Counter()
    for p in (1, 2):
        per = Counter()
        for t in make_plan(cfg, p):
            left, right = (s["condition"] for s in t["slots"])
            per[(left, right)] += 1
            total[(left, right)] += 1
        for a, b in (("x", "y"), ("x", "z"), ("y", "z")):
            assert abs(per[(a, b)] - per[(b, a)]) <= 1
    for a, b in (("x", "y"), ("x", "z"), ("y", "z")):
        assert total[(a, b)] == total[(b, a)] == 5


def test_public_trial_hides_systems_and_blinds_ids(examples_dir):
    cfg = load_config(examples_dir / "listening" / "mushra.yaml")
    trial = make_plan(cfg, 3)[0]
    pub = public_trial(trial, cfg, secret=b"k" * 32, participant=3)
    text = repr(pub)
    for cond in ("reference", "system", "desync", "noise"):
        assert f"'{cond}'" not in text.replace("'reference':", "")
    ids = [pub["reference"]["id"]] + [s["stimulus"]["id"] for s in pub["slots"]]
    assert len(set(ids)) == len(ids)  # hidden reference does not share the reference's id
    hidden = next(s for s in trial["slots"] if s["condition"] == "reference")
    assert hidden["stimulus"] == trial["reference"]
    for i, sid in zip(ids, [trial["reference"]] + [s["stimulus"] for s in trial["slots"]]):
        assert unblind_id(i, b"k" * 32) == sid
    assert unblind_id("zz", b"k" * 32) is None
    assert blind_id("00" * 8, "a", b"k") != blind_id("00" * 8, "b", b"k")


def test_cli_serve_with_malformed_config_names_the_line(test_dir, capsys):
    from headmotion.cli import main

    p = _write(test_dir, GOOD.replace("speaker: A", "speaker: [A"))
    assert main(["listen", "serve", str(p), "--port", "1"]) == 1  # bad input (documented exit codes)
    err = capsys.readouterr().err
    assert "bad.yaml, line" in err and "invalid YAML" in err
