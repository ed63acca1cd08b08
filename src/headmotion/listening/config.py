"""Listening-test configuration: a YAML file validated line by line (thesis §4.2.3–4.2.4, §5.5.1;
paper §4.4).

One YAML file describes one test.  Three test types are supported:

``mos_ref``
    MOS with a labelled reference (thesis §4.2.3): the motion-capture reference on the left, one
    stimulus on the right, a 7-point scale "How similar is the video on the right to the video on
    the left".  Each (item, condition) is one trial.
``mushra``
    MUSHRA (ITU-R BS.1534; paper §4.4): a labelled reference and all conditions of an item at once
    (including the hidden reference and the anchor) on 0–100 sliders marked Bad/Poor/Fair/Good/
    Excellent.  Each item is one trial.
``ab``
    A/B forced choice (thesis §5.5.1, Table 5.4): each (item, pair of conditions) is one trial; each
    pair is shown equally often on each side.

A stimulus is either an mp4 file (``video: clip.mp4`` or just ``clip.mp4``) or motion + audio
rendered in the browser by the viewer component (``{motion: m.npz, audio: a.wav}``).  Paths are
relative to the config file's folder and may not leave it.

Errors name the file and line: the YAML is *composed* (not just loaded) so that every mapping key
and value keeps its :class:`yaml.Mark`.  Libraries considered: pydantic (good messages but no YAML
line numbers without a custom loader, which is what this module is), strictyaml (not installed,
narrower YAML).  Parsing uses PyYAML's node marks directly.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import FormatError
from .config_yaml import _compose, _Ctx, _Node

TEST_TYPES = ("mos_ref", "mushra", "ab")
DEFAULT_QUESTIONS = {
    "mos_ref": "How similar is the video on the right to the video on the left?",
    "mushra": "Rate how natural the head motion of each video is, compared with the reference.",
    "ab": "In which video does the head motion look more natural?",
}
DEFAULT_MOS_LABELS = ("1 – very different", "2", "3", "4", "5", "6", "7 – identical")
MUSHRA_MARKS = ("Bad", "Poor", "Fair", "Good", "Excellent")
VIEWER_STYLES = ("textured", "smooth", "silhouette")
VIDEO_SUFFIXES = (".mp4", ".webm", ".m4v", ".ogv")
MOTION_SUFFIXES = (".npz", ".json", ".csv", ".bvh")
AUDIO_SUFFIXES = (".wav", ".mp3", ".ogg", ".flac", ".m4a")


# ---------------------------------------------------------------------------------------------
# The configuration objects
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Stimulus:
    """One stimulus: an mp4 file or motion + audio for the browser viewer.

    ``id`` is an opaque, stable identifier (a hash of the relative paths) used in URLs so that the
    participant's browser never sees file names or system names."""

    id: str
    video: Path | None = None
    motion: Path | None = None
    audio: Path | None = None

    @property
    def kind(self) -> str:
        return "video" if self.video is not None else "motion"

    def files(self) -> dict[str, Path]:
        return {k: v for k, v in (("video", self.video), ("motion", self.motion),
                                  ("audio", self.audio)) if v is not None}


@dataclass(frozen=True)
class Item:
    """One item: a reference (optional for A/B) and the conditions (system name → stimulus)."""

    id: str
    conditions: dict[str, Stimulus]
    reference: Stimulus | None = None
    speaker: str = ""
    group: str = ""
    pairs: tuple[tuple[str, str], ...] = ()
    line: int | None = None


@dataclass(frozen=True)
class Question:
    """One demographics question: ``choice`` (from ``options``), ``text`` or ``number``."""

    name: str
    label: str
    type: str = "choice"
    options: tuple[str, ...] = ()
    required: bool = True


@dataclass(frozen=True)
class AttentionCheck:
    """A check inserted after ``after`` test trials: a question with one right ``answer``."""

    after: int
    question: str
    options: tuple[str, ...]
    answer: str


@dataclass(frozen=True)
class TestConfig:
    """A validated listening-test configuration (see the module docstring)."""

    path: Path
    root: Path
    type: str
    items: tuple[Item, ...]
    title: str = "Head motion evaluation"
    name: str = "test"
    seed: int = 0
    consent: str = ""
    instructions: str = ""
    question: str = ""
    scale_points: int = 7
    scale_labels: tuple[str, ...] = DEFAULT_MOS_LABELS
    demographics: tuple[Question, ...] = ()
    training: tuple[Item, ...] = ()
    attention_checks: tuple[AttentionCheck, ...] = ()
    hidden_reference: str = "reference"
    anchor: str | None = None
    screening_threshold: float = 90.0
    screening_fraction: float = 0.85
    require_play: bool = False
    viewer_style: str = "textured"
    admin_token: str | None = None
    database: str | None = None
    finish_text: str = "Thank you for taking part!"
    #: server limits: a cap on participants (None: no cap) and at most
    #: ``registrations_per_address`` new participants per client address per
    #: ``registration_window_s`` seconds
    max_participants: int | None = None
    registrations_per_address: int = 30
    registration_window_s: float = 3600.0
    digest: str = ""
    stimuli: dict[str, Stimulus] = field(default_factory=dict)

    @property
    def n_trials(self) -> int:
        """Number of trials a participant sees (training + test + attention checks)."""
        return sum(_trials_per_item(self, it) for it in self.training + self.items) + len(
            self.attention_checks)

    def default_database_url(self) -> str:
        """SQLite file beside the config: ``results/<name>.sqlite`` (one file per test)."""
        return f"sqlite:///{self.root / 'results' / (self.name + '.sqlite')}"

    def public_info(self) -> dict[str, Any]:
        """What any participant may read: texts, scale and questionnaire (no system names)."""
        return {
            "name": self.name, "title": self.title, "type": self.type, "consent": self.consent,
            "instructions": self.instructions, "question": self.question,
            "scale_points": self.scale_points, "scale_labels": list(self.scale_labels),
            "mushra_marks": list(MUSHRA_MARKS), "require_play": self.require_play,
            "viewer_style": self.viewer_style,
            "finish_text": self.finish_text, "n_trials": self.n_trials,
            "demographics": [
                {"name": q.name, "label": q.label, "type": q.type, "options": list(q.options),
                 "required": q.required} for q in self.demographics],
        }


def _trials_per_item(cfg: TestConfig, item: Item) -> int:
    if cfg.type == "mos_ref":
        return len(item.conditions)
    if cfg.type == "mushra":
        return 1
    return len(item.pairs)


# ---------------------------------------------------------------------------------------------
# Parsing
# ---------------------------------------------------------------------------------------------
_TOP_KEYS = {"type", "title", "name", "seed", "consent", "instructions", "question", "scale",
             "demographics", "training", "items", "attention_checks", "mushra", "ab",
             "require_play", "admin_token", "database", "finish_text", "viewer_style",
             "max_participants", "registrations_per_address", "registration_window_s"}


def load_config(path) -> TestConfig:
    """Read and validate a test configuration.

    Parameters
    ----------
    path : str or Path
        The YAML file.  Stimulus paths in it are relative to its folder.

    Raises
    ------
    FormatError
        Naming the file and the line of the offending value, and what was expected.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise FormatError("the test configuration does not exist", path=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise FormatError(f"cannot read the test configuration: {exc}", path=path) from None
    root_dir = path.resolve().parent
    ctx = _Ctx(path, root_dir)
    root = _compose(text, path)
    top = ctx.mapping(root, "the test configuration")
    ctx.keys(top, _TOP_KEYS, "the test configuration", root)
    if "type" not in top:
        ctx.fail(f"missing 'type'; expected one of {', '.join(TEST_TYPES)}", root)
    ttype = ctx.string(top["type"], "'type'")
    if ttype not in TEST_TYPES:
        ctx.fail(f"'type' must be one of {', '.join(TEST_TYPES)}; got {ttype!r}", top["type"])

    kw = _general_settings(ctx, top, ttype, path)
    _scale_settings(ctx, top, kw)
    _demographics_settings(ctx, top, kw)
    _mushra_settings(ctx, top, ttype, kw)
    stimuli = _items_and_checks(ctx, top, root, ttype, kw)
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    return TestConfig(path=path, root=root_dir, type=ttype, digest=digest, stimuli=stimuli, **kw)


def _general_settings(ctx: _Ctx, top: dict, ttype: str, path: Path) -> dict[str, Any]:
    """The test's texts, name, seed, viewer style and server limits, as keywords of :class:`TestConfig`."""
    kw: dict[str, Any] = {}
    for key in ("title", "consent", "instructions", "question", "finish_text", "admin_token",
                "database"):
        if key in top and top[key].value is not None:
            kw[key] = ctx.string(top[key], f"'{key}'", allow_empty=key != "title")
    kw.setdefault("question", DEFAULT_QUESTIONS[ttype])
    if "name" in top:
        name = ctx.string(top["name"], "'name'")
        if not all(c.isalnum() or c in "-_." for c in name):
            ctx.fail(f"'name' may only hold letters, digits, '-', '_' and '.'; got {name!r}",
                     top["name"])
        kw["name"] = name
    else:
        kw["name"] = path.stem
    if "seed" in top:
        kw["seed"] = ctx.integer(top["seed"], "'seed'", 0, 2**63 - 1)
    if "viewer_style" in top:
        style = ctx.string(top["viewer_style"], "'viewer_style'")
        if style not in VIEWER_STYLES:
            ctx.fail(f"'viewer_style' must be one of {', '.join(VIEWER_STYLES)} (thesis §4.2.3); "
                     f"got {style!r}", top["viewer_style"])
        kw["viewer_style"] = style
    if "require_play" in top:
        kw["require_play"] = ctx.boolean(top["require_play"], "'require_play'")
    if "max_participants" in top and top["max_participants"].value is not None:
        kw["max_participants"] = ctx.integer(top["max_participants"], "'max_participants'", 1, 10**7)
    if "registrations_per_address" in top:
        kw["registrations_per_address"] = ctx.integer(top["registrations_per_address"],
                                                      "'registrations_per_address'", 1, 10**7)
    if "registration_window_s" in top:
        kw["registration_window_s"] = ctx.number(top["registration_window_s"], "'registration_window_s'",
                                                 1, 366 * 24 * 3600)
    return kw


def _scale_settings(ctx: _Ctx, top: dict, kw: dict[str, Any]) -> None:
    """``scale:`` (points and their labels) into ``kw``."""
    if "scale" in top:
        sc = ctx.mapping(top["scale"], "'scale'")
        ctx.keys(sc, {"points", "labels"}, "'scale'", top["scale"])
        points = ctx.integer(sc["points"], "'scale.points'", 2, 11) if "points" in sc else 7
        kw["scale_points"] = points
        if "labels" in sc:
            labels = tuple(ctx.string(n, "a scale label") for n in ctx.seq(sc["labels"],
                                                                          "'scale.labels'"))
            if len(labels) != points:
                ctx.fail(f"'scale.labels' must have one label per point ({points}); "
                         f"got {len(labels)}", sc["labels"])
            kw["scale_labels"] = labels
        else:
            kw["scale_labels"] = tuple(str(i + 1) for i in range(points)) if points != 7 else \
                DEFAULT_MOS_LABELS


def _demographics_settings(ctx: _Ctx, top: dict, kw: dict[str, Any]) -> None:
    """``demographics:`` (the questionnaire; names unique) into ``kw``."""
    if "demographics" in top:
        kw["demographics"] = tuple(_question(ctx, n) for n in ctx.seq(top["demographics"],
                                                                      "'demographics'"))
        names = [q.name for q in kw["demographics"]]
        for q, n in zip(kw["demographics"], top["demographics"].value):
            if names.count(q.name) > 1:
                ctx.fail(f"demographics question name {q.name!r} is used twice", n)


def _mushra_settings(ctx: _Ctx, top: dict, ttype: str, kw: dict[str, Any]) -> None:
    """``mushra:`` (hidden reference, anchor, screening) into ``kw``; refused for other test types."""
    if ttype == "mushra" and "mushra" in top:
        ms = ctx.mapping(top["mushra"], "'mushra'")
        ctx.keys(ms, {"hidden_reference", "anchor", "screening_threshold", "screening_fraction"},
                 "'mushra'", top["mushra"])
        if "hidden_reference" in ms:
            kw["hidden_reference"] = ctx.string(ms["hidden_reference"], "'mushra.hidden_reference'")
        if "anchor" in ms:
            kw["anchor"] = ctx.string(ms["anchor"], "'mushra.anchor'")
        if "screening_threshold" in ms:
            kw["screening_threshold"] = ctx.number(ms["screening_threshold"],
                                                   "'mushra.screening_threshold'", 0, 100)
        if "screening_fraction" in ms:
            kw["screening_fraction"] = ctx.number(ms["screening_fraction"],
                                                  "'mushra.screening_fraction'", 0, 1)
    elif "mushra" in top:
        ctx.fail(f"'mushra' settings only apply to type: mushra (this test is {ttype})", top["mushra"])
    if "ab" in top:
        ctx.fail("'ab' is not a settings block; pairs are given per item with 'pairs:'", top["ab"])


def _items_and_checks(ctx: _Ctx, top: dict, root: _Node, ttype: str, kw: dict[str, Any]) -> dict[str, Stimulus]:
    """``items:``, ``training:`` (ids unique over both) and ``attention_checks:`` into ``kw``;
    returns the stimuli they name."""
    path, root_dir = ctx.path, ctx.root_dir
    stimuli: dict[str, Stimulus] = {}
    if "items" not in top:
        ctx.fail("missing 'items': the list of items to rate", root)
    kw["items"] = tuple(_item(ctx, n, ttype, stimuli, kw) for n in ctx.seq(top["items"], "'items'"))
    if not kw["items"]:
        ctx.fail("'items' is empty; a test needs at least one item", top["items"])
    if "training" in top and top["training"].value is not None:
        kw["training"] = tuple(_item(ctx, n, ttype, stimuli, kw)
                               for n in ctx.seq(top["training"], "'training'"))
    seen: dict[str, int] = {}
    for it in kw.get("training", ()) + kw["items"]:
        if it.id in seen:
            raise FormatError(f"item id {it.id!r} is used twice (first on line {seen[it.id]})",
                              path=path, line=it.line)
        seen[it.id] = it.line
    if "attention_checks" in top and top["attention_checks"].value is not None:
        n_test = sum(_trials_per_item(TestConfig(path=path, root=root_dir, type=ttype, items=()),
                                      it) for it in kw["items"])
        kw["attention_checks"] = tuple(_attention(ctx, n, n_test)
                                       for n in ctx.seq(top["attention_checks"],
                                                        "'attention_checks'"))
    return stimuli


def _question(ctx: _Ctx, node: _Node) -> Question:
    m = ctx.mapping(node, "a demographics question")
    ctx.keys(m, {"name", "label", "type", "options", "required"}, "a demographics question", node)
    if "name" not in m:
        ctx.fail("a demographics question needs a 'name'", node)
    name = ctx.string(m["name"], "'name'")
    if not name.replace("_", "").isalnum():
        ctx.fail(f"question name {name!r} may only hold letters, digits and '_'", m["name"])
    qtype = ctx.string(m["type"], "'type'") if "type" in m else "choice"
    if qtype not in ("choice", "text", "number"):
        ctx.fail(f"question type must be choice, text or number; got {qtype!r}", m["type"])
    options: tuple[str, ...] = ()
    if qtype == "choice":
        if "options" not in m:
            ctx.fail(f"choice question {name!r} needs 'options'", node)
        options = tuple(ctx.string(o, "an option") for o in ctx.seq(m["options"], "'options'"))
        if len(options) < 2:
            ctx.fail(f"choice question {name!r} needs at least two options", m["options"])
    label = ctx.string(m["label"], "'label'") if "label" in m else name.replace("_", " ")
    required = ctx.boolean(m["required"], "'required'") if "required" in m else True
    return Question(name=name, label=label, type=qtype, options=options, required=required)


def _stimulus(ctx: _Ctx, node: _Node, what: str, stimuli: dict[str, Stimulus]) -> Stimulus:
    if isinstance(node.value, dict):
        m = node.value
        ctx.keys(m, {"video", "motion", "audio"}, what, node)
        if "video" in m:
            if "motion" in m:
                ctx.fail(f"{what} gives both 'video' and 'motion'; give one", node)
            video = ctx.file(m["video"], "video", VIDEO_SUFFIXES)
            audio = ctx.file(m["audio"], "audio", AUDIO_SUFFIXES) if "audio" in m else None
            files = {"video": video, "audio": audio}
        elif "motion" in m:
            if "audio" not in m:
                ctx.fail(f"{what} gives 'motion' but no 'audio'", node)
            files = {"motion": ctx.file(m["motion"], "motion", MOTION_SUFFIXES),
                     "audio": ctx.file(m["audio"], "audio", AUDIO_SUFFIXES)}
        else:
            ctx.fail(f"{what} must give 'video' or 'motion' + 'audio'", node)
    else:
        files = {"video": ctx.file(node, what, VIDEO_SUFFIXES)}
    rel = "|".join(f"{k}={v.relative_to(ctx.root_dir).as_posix()}" for k, v in files.items()
                   if v is not None)
    sid = hashlib.sha256(rel.encode()).hexdigest()[:16]
    stim = Stimulus(id=sid, **{k: v for k, v in files.items() if v is not None})
    stimuli[sid] = stim
    return stim


def _item(ctx: _Ctx, node: _Node, ttype: str, stimuli: dict, kw: dict) -> Item:
    m = ctx.mapping(node, "an item")
    ctx.keys(m, {"id", "speaker", "group", "reference", "conditions", "pairs"}, "an item", node)
    if "id" not in m:
        ctx.fail("an item needs an 'id'", node)
    iid = ctx.string(m["id"], "'id'")
    if "conditions" not in m:
        ctx.fail(f"item {iid!r} needs 'conditions' (system name: stimulus)", node)
    cm = ctx.mapping(m["conditions"], f"'conditions' of item {iid!r}")
    conditions = {str(k): _stimulus(ctx, v, f"condition {k!r}", stimuli) for k, v in cm.items()}
    if not conditions:
        ctx.fail(f"item {iid!r} has no conditions", m["conditions"])
    reference = None
    if "reference" in m:
        reference = _stimulus(ctx, m["reference"], "'reference'", stimuli)
    elif ttype in ("mos_ref", "mushra"):
        ctx.fail(f"item {iid!r} needs a 'reference' (the labelled motion-capture reference) in a "
                 f"{ttype} test", node)
    pairs: tuple[tuple[str, str], ...] = ()
    if ttype == "ab":
        if len(conditions) < 2:
            ctx.fail(f"item {iid!r} needs at least two conditions for an A/B test", m["conditions"])
        if "pairs" in m:
            plist = []
            for pn in ctx.seq(m["pairs"], "'pairs'"):
                p = [ctx.string(x, "a condition name") for x in ctx.seq(pn, "a pair")]
                if len(p) != 2 or p[0] == p[1]:
                    ctx.fail(f"a pair must name two different conditions; got {p}", pn)
                for c in p:
                    if c not in conditions:
                        ctx.fail(f"pair names condition {c!r}, which item {iid!r} does not have; "
                                 f"it has {sorted(conditions)}", pn)
                plist.append((p[0], p[1]))
            pairs = tuple(plist)
        else:
            names = list(conditions)
            pairs = tuple((a, b) for i, a in enumerate(names) for b in names[i + 1:])
    elif "pairs" in m:
        ctx.fail(f"'pairs' only applies to A/B tests (this test is {ttype})", m["pairs"])
    if ttype == "mushra":
        hidden = kw.get("hidden_reference", "reference")
        if hidden not in conditions:
            ctx.fail(f"MUSHRA item {iid!r} must include the hidden reference as condition "
                     f"{hidden!r}; it has {sorted(conditions)}", m["conditions"])
        anchor = kw.get("anchor")
        if anchor is not None and anchor not in conditions:
            ctx.fail(f"MUSHRA item {iid!r} must include the anchor condition {anchor!r}; "
                     f"it has {sorted(conditions)}", m["conditions"])
    speaker = ctx.string(m["speaker"], "'speaker'") if "speaker" in m else ""
    group = ctx.string(m["group"], "'group'") if "group" in m else ""
    return Item(id=iid, conditions=conditions, reference=reference, speaker=speaker, group=group,
                pairs=pairs, line=node.line)


def _attention(ctx: _Ctx, node: _Node, n_test: int) -> AttentionCheck:
    m = ctx.mapping(node, "an attention check")
    ctx.keys(m, {"after", "question", "options", "answer"}, "an attention check", node)
    for k in ("after", "question", "options", "answer"):
        if k not in m:
            ctx.fail(f"an attention check needs {k!r}", node)
    after = ctx.integer(m["after"], "'after'", 0, n_test)
    options = tuple(ctx.string(o, "an option") for o in ctx.seq(m["options"], "'options'"))
    answer = ctx.string(m["answer"], "'answer'")
    if answer not in options:
        ctx.fail(f"the answer {answer!r} is not one of the options {list(options)}", m["answer"])
    return AttentionCheck(after=after, question=ctx.string(m["question"], "'question'"),
                          options=options, answer=answer)


__all__ = ["TestConfig", "Item", "Stimulus", "Question", "AttentionCheck", "load_config",
           "TEST_TYPES", "MUSHRA_MARKS"]
