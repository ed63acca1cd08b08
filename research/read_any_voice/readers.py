"""Pitch / voicing readers measured frame by frame against Praat's whole-file reading.

Reference: Praat's autocorrelation pitch (parselmouth, 75-500 Hz, 10 ms step) on the whole CLEAN
file, as :func:`headmotion.features.prosody.praat_pitch` reads it at 100 fps: its voicing flag, and
its F0 on the frames it calls voiced.  Every candidate reads the clean file and each degraded copy
(:func:`headmotion.evaluation.protocol.degraded.degrade`: noise20, telephone, quiet, mp3-64k); a
degraded copy is still scored against Praat on the clean audio (what was said).

Per reader, source / file and condition: voicing agreement, recall and precision against Praat;
on frames both call voiced, median |log F0 error| (semitones), the share > 5 st apart and the share
near an octave (11-13 st); the lag (-100..+100 ms) that maximises voicing agreement (positive: the
reader is late); of Praat's speech hops (0.6 s = 15 frames at 25 fps, speech when >= 20 % of its
10 ms frames are voiced) the share the reader calls a pause (and the converse); CPU (process time)
per second of audio, and for the causal readers per call and per 10 ms of audio.

Material: the talking-video corpus (~/.cache/headmotion/corpus/talking_video, pooled per source)
and the speech-only set (/work/shared/data/speech minus video_retalking_1.wav, plus
examples/speech), all read at 16 kHz.  To fit ~25 minutes on 2 shared cores, the costly readers
run on fewer conditions and on a subset (every 3rd corpus recording + the speech set): see
:func:`plan` (``--all`` runs everything everywhere); the subset tables compare all readers like for
like.  Not run: PESTO (needs PyTorch).  Results are cached per (file, condition, reader) in
.scratch/readers/stats.jsonl, so a rerun only computes what is missing (--fresh to start over);
the tables go to .scratch/readers/readers.md.

    nice -n 10 .venv/bin/python research/read_any_voice/readers.py            # everything
    nice -n 10 .venv/bin/python research/read_any_voice/readers.py --limit 2 --readers yin045,swift
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import re
import sys
import time
import types
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402

# pyworld and pyreaper import pkg_resources only to read their own version; setuptools >= 81 (or
# none, as in this venv) lacks it, so give them a stand-in instead of changing the environment.
if "pkg_resources" not in sys.modules:
    _pr = types.ModuleType("pkg_resources")
    _pr.get_distribution = lambda _name: types.SimpleNamespace(version="unknown")
    sys.modules["pkg_resources"] = _pr

SR, FPS, FLOOR, CEIL = 16000, 100, 75.0, 500.0
ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / ".scratch" / "readers"
CORPUS = Path.home() / ".cache/headmotion/corpus/talking_video"
SPEECH = [p for p in sorted(Path("/work/shared/data/speech").glob("*")) if p.name != "video_retalking_1.wav"] \
    + sorted((ROOT / "examples/speech").glob("*.wav"))
SOURCES = ["dfrf", "grid", "mimictalk", "pc_avs", "sadtalker", "styletalk", "video_retalking", "mead_lrs3"]
CONDITIONS = ["clean", "noise20", "telephone", "quiet", "mp3-64k"]
DEFAULT_READERS = ("praat-whole,praat-block10,praat-block30,yin045,yin035,yin045-nojump,yin035-nojump,"
                   "praat-causal0.3,praat-causal0.5,praat-causal1.0,praat-causal2.0,praat-causal0.5-sil0.01,"
                   "praat-causal0.5-sil0.1,praat-causal0.5-s1,praat-causal0.5-hold,pyin,pyin-fl1024,harvest,"
                   "dio,reaper,swift,praat-path,praat-live0.3")
SHIFTS = np.arange(-10, 11)          # lag search, frames of 10 ms
HOP = 60                             # 15 frames at 25 fps = 60 frames at 100 fps


def plan(name: str):
    """(conditions, subset only) a reader runs on by default, to fit ~25 min on 2 shared cores:
    CPU per second of audio measured on a dry run (2 files, 62 s) sets the tier (--all: everything)."""
    m = re.match(r"praat-causal([\d.]+)(.*)", name)
    if name.startswith("pyin") or name == "harvest" or (m and m.group(2)):            # 190-260 ms/s; variants of 0.5
        return ["clean"], True
    if name == "praat-live0.3":   # one Praat call per 10 ms frame on 0.3 s: ~150 ms/s
        return ["clean"], False
    if name == "reaper" or (m and float(m.group(1)) >= 1.0):         # 115-220 ms/s
        return ["clean", "noise20"], True
    if m:   # 35-60 ms/s; Praat is scale-invariant, so 'quiet' repeats 'clean' (dry run: identical)
        return ["clean", "noise20", "telephone", "mp3-64k"], False
    return CONDITIONS, False                                         # <= 15 ms/s


# -- material -------------------------------------------------------------------------------------
def material(limit: int | None):
    """[(file id, group, path, in subset)]: the corpus recordings pooled by source, the speech files
    by name; the subset (heavy readers) is every 3rd corpus recording and every speech file."""
    items = []
    with open(CORPUS / "corpus.csv", newline="") as f:
        for row in csv.DictReader(f):
            src = row.get("source") or next((s for s in SOURCES if row["recording"].startswith(s + "_")), "other")
            if (CORPUS / row["audio"]).exists():
                items.append((row["recording"], src, CORPUS / row["audio"], len(items) % 3 == 0))
    items += [(f"speech:{p.stem}", f"speech:{p.stem}", p, True) for p in SPEECH]
    if limit:   # a few of each kind, for a dry run
        items = items[:limit] + [i for i in items if i[0].startswith("speech:")][:limit]
    return items


def centres(n: int) -> np.ndarray:
    return (np.arange(n) + 0.5) / FPS


def on_grid(times, f0, voiced, n):
    """A reader's frames (times in s) mapped onto our 100 fps centres by the nearest frame."""
    times = np.asarray(times, dtype=np.float64)
    if len(times) == 0:
        return np.zeros(n), np.zeros(n, bool)
    dt = times[1] - times[0] if len(times) > 1 else 0.01
    k = np.clip(np.floor((centres(n) - times[0]) / dt + 0.5).astype(int), 0, len(times) - 1)
    v = np.asarray(voiced, bool)[k]
    return np.where(v, np.asarray(f0, np.float64)[k], 0.0), v


# -- readers: each returns (f0 Hz (0 where unvoiced), voiced bool, extra dict) ----------------------
def praat_track(x, *, start=0.0, silence=0.03):
    """Praat's AC pitch of ``x`` placed at ``start`` s: (frame times, F0 with 0 = unvoiced)."""
    import parselmouth
    snd = parselmouth.Sound(x, sampling_frequency=float(SR), start_time=start)
    try:
        p = snd.to_pitch_ac(time_step=0.01, pitch_floor=FLOOR, pitch_ceiling=CEIL, silence_threshold=silence)
    except parselmouth.PraatError:       # shorter than Praat's window
        return np.zeros(0), np.zeros(0)
    return np.asarray(p.xs()), np.asarray(p.selected_array["frequency"], np.float64)


def read_praat_whole(x, n):
    from headmotion.features.prosody import praat_pitch
    from headmotion.types import Audio
    f0, v = praat_pitch(Audio(x.astype(np.float32), SR), fps=FPS, n_frames=n, pitch_step=0.01)
    return np.where(v, f0, 0.0), v, {}


def read_block(x, n, block_s, margin_s=1.0):
    """Praat on blocks of ``block_s`` with ``margin_s`` on both sides; frames from the middle."""
    f0, v = np.zeros(n), np.zeros(n, bool)
    c = centres(n)
    for b0 in np.arange(0, n / FPS, block_s):
        a, e = max(0.0, b0 - margin_s), min(len(x) / SR, b0 + block_s + margin_s)
        t, f = praat_track(x[int(round(a * SR)):int(round(e * SR))], start=a)
        sel = (c >= b0) & (c < b0 + block_s)
        if len(t) and sel.any():
            ff, vv = on_grid(t, f, f > 0, n)
            f0[sel], v[sel] = ff[sel], vv[sel]
    return f0, v, {}


def read_causal(x, n, window_s, stride=4, hold=False, silence=0.03):
    """Praat on the last ``window_s`` of audio ending 30 ms past a frame centre, once per
    ``stride`` frames; the call serves the ``stride`` frames up to that frame (each its nearest
    Praat frame), or with ``hold`` the first frame's value is held for the next ``stride - 1``."""
    f0, v = np.zeros(n), np.zeros(n, bool)
    calls = 0
    for t0 in range(0, n, stride):
        frames = np.arange(t0, min(t0 + stride, n))
        last = frames[0] if hold else frames[-1]
        end = min(len(x), int(round(((last + 0.5) / FPS + 0.03) * SR)))
        start = max(0, end - int(round(window_s * SR)))
        t, f = praat_track(x[start:end], start=start / SR, silence=silence)
        calls += 1
        if not len(t):
            continue
        want = np.full(len(frames), (last + 0.5) / FPS) if hold else (frames + 0.5) / FPS
        k = np.clip(np.floor((want - t[0]) / (t[1] - t[0] if len(t) > 1 else 0.01) + 0.5).astype(int), 0, len(t) - 1)
        f0[frames], v[frames] = f[k], f[k] > 0
    return f0, v, {"calls": calls}


def _read_f0e_live(x, n, **params):
    """The project's f0e-live extractor read whole at FPS with ``params``; smooth_frames=1 so
    ``logf0`` is the raw held value, F0 taken where ``voiced``."""
    from headmotion.features import extract
    from headmotion.types import Audio
    tr = extract("f0e-live", Audio(x.astype(np.float32), SR), fps=FPS, n_frames=n, voicing=True, smooth_frames=1,
                 **params)
    v = tr.values[:, list(tr.names).index("voiced")] > 0.5
    return np.where(v, np.exp(tr.values[:, list(tr.names).index("logf0")].astype(np.float64)), 0.0), v, {}


def read_yin(x, n, thr, jump):
    """The project's streaming YIN (the default 10-frame average would only blur it)."""
    return _read_f0e_live(x, n, voicing_threshold=thr, max_jump_semitones=jump)


def read_live03(x, n):
    """The stream's former reader (``reader="praat"`` live: Praat on the last 0.3 s for every frame,
    the running peak) at a 20 ms step."""
    from headmotion.systems.motion_match.library import PRAAT_LIVE
    return _read_f0e_live(x, n, **PRAAT_LIVE)


def read_path(x, n):
    """The shipped stream's reader (``reader="praat-path"``: Praat's candidates of every 20 ms analysis
    frame, its path searched forward)."""
    return _read_f0e_live(x, n, reader="praat-path", praat_step=0.02)


def yin_params(name: str):
    """``yin045[-nojump]`` -> (voicing threshold 0.45, octave guard 5 st or 0 = off)."""
    m = re.fullmatch(r"yin0(\d\d)(-nojump)?", name)
    if not m:
        raise SystemExit(f"unknown reader {name!r}")
    return int(m.group(1)) / 100, 0.0 if m.group(2) else 5.0


def yin_stream_cost(x, thr, jump):
    """CPU s of the live path: StreamingF0e (default smoothing) pushed 10 ms at a time."""
    from headmotion.features.streaming import StreamingF0e
    ex = StreamingF0e(sample_rate=SR, fps=FPS, voicing=True, voicing_threshold=thr, max_jump_semitones=jump)
    c0 = time.process_time()
    for i in range(0, len(x), SR // FPS):
        ex.push(x[i:i + SR // FPS])
    ex.flush()
    return time.process_time() - c0


PAD = SR // FPS // 2   # 80 samples: a reader with frames at k * 10 ms then has frame k+1 on our centre k


def read_pyin(x, n, frame_length=2048):
    """pYIN; librosa's default frame of 2048 samples is 128 ms at 16 kHz (``pyin-fl1024``: 64 ms)."""
    import librosa
    f, vf, _ = librosa.pyin(np.r_[np.zeros(PAD), x], fmin=FLOOR, fmax=CEIL, sr=SR, hop_length=SR // FPS,
                            frame_length=frame_length)
    t = np.arange(len(f)) / FPS - PAD / SR
    return (*on_grid(t, np.nan_to_num(f), vf, n), {})


def read_world(x, n, which):
    import pyworld
    xp = np.ascontiguousarray(np.r_[np.zeros(PAD), x], dtype=np.float64)
    if which == "harvest":
        f, t = pyworld.harvest(xp, SR, f0_floor=FLOOR, f0_ceil=CEIL, frame_period=10.0)
    else:
        f, t = pyworld.dio(xp, SR, f0_floor=FLOOR, f0_ceil=CEIL, frame_period=10.0)
        f = pyworld.stonemask(xp, f, t, SR)
    return (*on_grid(t - PAD / SR, f, f > 0, n), {})


def read_reaper(x, n):
    import pyreaper
    xi = (np.clip(np.r_[np.zeros(PAD), x], -1, 1) * 32767).astype(np.int16)
    sys.stdout.flush()
    saved = os.dup(1)                        # REAPER prints diagnostics on the C stdout
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
    try:
        _, _, t, f, _ = pyreaper.reaper(xi, SR, minf0=FLOOR, maxf0=CEIL, frame_period=0.01)
    finally:
        os.dup2(saved, 1)
        os.close(saved)
    f = np.asarray(f, np.float64)
    return (*on_grid(np.asarray(t, np.float64) - PAD / SR, f, f > 0, n), {})


_SWIFT = None


def read_swift(x, n):
    """SwiftF0 (16 ms hop, frame k centred at k * 16 ms), voiced at confidence >= 0.5."""
    global _SWIFT
    import swift_f0
    _SWIFT = _SWIFT or swift_f0.SwiftF0(threads=1, spin=False)
    r = _SWIFT.detect(x.astype(np.float32), SR, fmin=FLOOR, fmax=CEIL)
    return (*on_grid(r.timestamps, r.pitch_hz, r.confidence >= 0.5, n), {})


def reader(name: str):
    """The function ``(x, n) -> (f0, voiced, extra)`` for a reader name (see DEFAULT_READERS)."""
    if name == "praat-whole":
        return read_praat_whole
    if m := re.fullmatch(r"praat-block(\d+)", name):
        return lambda x, n: read_block(x, n, float(m.group(1)))
    if name.startswith("yin"):
        return lambda x, n: read_yin(x, n, *yin_params(name))
    if m := re.fullmatch(r"praat-causal([\d.]+)((?:-s\d+|-hold|-sil[\d.]+)*)", name):
        opts = m.group(2)
        s = re.search(r"-s(\d+)", opts)
        sil = re.search(r"-sil([\d.]+)", opts)
        return lambda x, n: read_causal(x, n, float(m.group(1)), stride=int(s.group(1)) if s else 4,
                                        hold="-hold" in opts, silence=float(sil.group(1)) if sil else 0.03)
    if m := re.fullmatch(r"pyin-fl(\d+)", name):
        return lambda x, n: read_pyin(x, n, int(m.group(1)))
    table = {"pyin": read_pyin, "harvest": lambda x, n: read_world(x, n, "harvest"),
             "dio": lambda x, n: read_world(x, n, "dio"), "reaper": read_reaper, "swift": read_swift,
             "praat-path": read_path, "praat-live0.3": read_live03}
    if name in table:
        return table[name]
    raise SystemExit(f"unknown reader {name!r}")


# -- scoring ----------------------------------------------------------------------------------------
def score(rf, rv, cf, cv):
    """Sufficient statistics of one reading against the reference (pooled later by summing)."""
    n = len(rv)
    both = rv & cv
    d = 12 * np.log2(cf[both] / rf[both])
    agree = [int(np.sum(rv[max(0, -s):n - max(0, s)] == cv[max(0, s):n - max(0, -s)])) for s in SHIFTS]
    nh = n // HOP
    rh = rv[:nh * HOP].reshape(nh, HOP).mean(1) >= 0.2
    ch = cv[:nh * HOP].reshape(nh, HOP).mean(1) >= 0.2
    return {"n": n, "tp": int(both.sum()), "fn": int((rv & ~cv).sum()), "fp": int((~rv & cv).sum()),
            "agree": agree, "nshift": [n - abs(int(s)) for s in SHIFTS],
            "d_cst": np.round(d * 100).astype(int).tolist(),
            "hops_speech": int(rh.sum()), "speech_as_pause": int((rh & ~ch).sum()),
            "hops_pause": int((~rh).sum()), "pause_as_speech": int((~rh & ch).sum())}


def pool(rows):
    """Pooled measures of cached rows (frames weighted equally)."""
    if not rows:
        return None
    s = lambda k: sum(r[k] for r in rows)  # noqa: E731
    n, tp, fn, fp = s("n"), s("tp"), s("fn"), s("fp")
    d = np.abs(np.concatenate([np.asarray(r["d_cst"], float) for r in rows])) / 100 if tp else np.zeros(0)
    ag = np.sum([r["agree"] for r in rows], 0) / np.sum([r["nshift"] for r in rows], 0)
    dur, cpu, calls = s("dur"), s("cpu"), s("calls")
    out = {"files": len(rows), "dur": dur, "agree": (n - fn - fp) / n, "recall": tp / max(tp + fn, 1),
           "precision": tp / max(tp + fp, 1), "med_st": float(np.median(d)) if len(d) else math.nan,
           "gt5": float(np.mean(d > 5)) if len(d) else math.nan,
           "oct": float(np.mean((d > 11) & (d < 13))) if len(d) else math.nan,
           "lag_ms": int(SHIFTS[np.argmax(ag)] * 10), "gain": float(ag.max() - ag[SHIFTS == 0][0]),
           "sp2pause": s("speech_as_pause") / max(s("hops_speech"), 1),
           "pause2sp": s("pause_as_speech") / max(s("hops_pause"), 1),
           "cpu_per_s": 1000 * cpu / dur, "ms_call": 1000 * cpu / calls if calls else math.nan,
           "ms_10ms": 1000 * cpu / (dur * FPS)}
    if any("cpu_stream" in r for r in rows):
        live = [r for r in rows if "cpu_stream" in r]
        out["ms_10ms"] = 1000 * sum(r["cpu_stream"] for r in live) / (sum(r["dur"] for r in live) * FPS)
    return out


COLS = [("files", "files", "{}"), ("dur", "audio s", "{:.0f}"), ("agree", "agree %", "{:.1%}"), ("recall", "recall %", "{:.1%}"),
        ("precision", "prec %", "{:.1%}"), ("med_st", "med abs err st", "{:.2f}"), ("gt5", ">5 st %", "{:.2%}"),
        ("oct", "11-13 st %", "{:.2%}"), ("lag_ms", "lag ms", "{:+d}"), ("gain", "agree gain at lag", "{:.1%}"),
        ("sp2pause", "speech hops as pause %", "{:.1%}"), ("pause2sp", "pause hops as speech %", "{:.1%}"),
        ("cpu_per_s", "CPU ms / s audio", "{:.0f}"), ("ms_call", "CPU ms / call", "{:.2f}"),
        ("ms_10ms", "CPU ms / 10 ms", "{:.3f}")]


def table(title, rows, key):
    """A markdown table: one row per (label, pooled dict)."""
    lines = [f"### {title}", "", f"| {key} | " + " | ".join(h for _, h, _ in COLS) + " |",
             "|---" * (len(COLS) + 1) + "|"]
    for label, p in rows:
        if p is None:
            continue
        cells = []
        for k, _, fmt in COLS:
            v = p[k]
            cells.append("–" if isinstance(v, float) and math.isnan(v) else fmt.format(v).replace("%", ""))
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def report(cache, readers, items):
    """All tables: pooled per condition, then per reader per group for clean and noise20."""
    groups = list(dict.fromkeys(i[1] for i in items))
    ids, sub = {i[0] for i in items}, {i[0] for i in items if i[3]}
    sel = lambda r, c, g=None, only=ids: [v for (f, cc, rr), v in cache.items()  # noqa: E731
                                          if rr == r and cc == c and f in only and (g is None or v["group"] == g)]
    md = ["# Pitch / voicing readers against Praat (whole clean file)", "",
          "Percent columns in %; `lag` > 0: the reader is late; `agree gain at lag`: voicing agreement "
          "at the best lag minus at 0; CPU ms / 10 ms for yin* is the live path pushed 10 ms at a time.", ""]
    for c in CONDITIONS:
        md.append(table(f"Pooled, {c} (every file the reader ran on)", [(r, pool(sel(r, c))) for r in readers], "reader"))
    for c in ("clean", "noise20"):
        md.append(table(f"Pooled, {c}, subset only (every 3rd corpus recording + the speech set: like for like)",
                        [(r, pool(sel(r, c, only=sub))) for r in readers], "reader"))
    for r in readers:
        for c in ("clean", "noise20"):
            md.append(table(f"{r}, {c}, per source / file", [(g, pool(sel(r, c, g))) for g in groups], "source"))
    return "\n".join(md)


def main(argv=None):
    """Run the readers over the material (each on the conditions and files of :func:`plan`), cache
    the statistics, write and print the tables."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--readers", default=DEFAULT_READERS)
    ap.add_argument("--conditions", default=",".join(CONDITIONS))
    ap.add_argument("--all", action="store_true", help="every reader on every condition and file (see plan)")
    ap.add_argument("--limit", type=int, help="only the first N corpus recordings and N speech files")
    ap.add_argument("--fresh", action="store_true", help="ignore the cached results")
    ap.add_argument("--out", type=Path, default=OUT)
    a = ap.parse_args(argv)
    from headmotion.align import n_frames
    from headmotion.evaluation.protocol.degraded import degrade
    from headmotion.io.audio import load_audio
    from headmotion.types import Audio

    readers, conds = a.readers.split(","), a.conditions.split(",")
    for r in readers:
        reader(r)
    a.out.mkdir(parents=True, exist_ok=True)
    store = a.out / "stats.jsonl"
    if a.fresh and store.exists():
        store.unlink()
    cache = {}
    if store.exists():
        for line in store.read_text().splitlines():
            d = json.loads(line)
            cache[(d["file"], d["cond"], d["reader"])] = d
    items = material(a.limit)
    print(f"{len(items)} files, readers {readers}, conditions {conds}", flush=True)
    warm = np.sin(2 * np.pi * 120 * np.arange(SR) / SR) * 0.3   # JIT / session start outside timing
    for r in readers:
        reader(r)(warm, FPS)
    t_start = time.time()
    with open(store, "a") as out:
        for fi, (fid, group, path, in_sub) in enumerate(items):
            x = load_audio(path, sample_rate=SR).samples.astype(np.float64)
            n = n_frames(len(x), SR, FPS)
            rf, rv, _ = read_praat_whole(x, n)
            for c in conds:
                todo = [r for r in readers if (fid, c, r) not in cache
                        and (a.all or (c in plan(r)[0] and (in_sub or not plan(r)[1])))]
                if not todo:
                    continue
                xd = degrade(Audio(x.astype(np.float32), SR), c).samples.astype(np.float64)
                for r in todo:
                    c0 = time.process_time()
                    cf, cv, extra = reader(r)(xd, n)
                    cpu = time.process_time() - c0
                    if cpu < 0.03 * len(x) / SR:   # a cheap reader: time a second call (the first pays page faults)
                        c0 = time.process_time()
                        reader(r)(xd, n)
                        cpu = min(cpu, time.process_time() - c0)
                    d = {"file": fid, "group": group, "cond": c, "reader": r, "dur": len(x) / SR, "cpu": cpu,
                         "calls": extra.get("calls", 0), **score(rf, rv, cf, cv)}
                    if r.startswith("yin") and c == "clean":
                        d["cpu_stream"] = yin_stream_cost(xd, *yin_params(r))
                    cache[(fid, c, r)] = d
                    out.write(json.dumps(d) + "\n")
                    out.flush()
            print(f"[{fi + 1}/{len(items)}] {fid} {len(x) / SR:.1f} s  ({time.time() - t_start:.0f} s)", flush=True)
    md = report(cache, readers, items)
    (a.out / "readers.md").write_text(md)
    print(md)


if __name__ == "__main__":
    main()
