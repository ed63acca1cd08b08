"""The real mocap pair, end to end through the CLI, skipped without
../shared: the ZEGGS take (BVH + wav of the same 68.8 s) is cut into folds at pauses in the speech,
imported with ``corpus import``, trained on with tws-hier and evaluated leave-one-out.  The same
folds written as OpenFace 2.x CSVs (30 fps, millisecond timestamps, a few failed frames) make a
corpus that trains and evaluates too: before the span-based rate, a 17 s OpenFace file read as
30.3 fps and failed the length check against its wav."""

from __future__ import annotations

import csv
import warnings

import numpy as np
import pytest

from headmotion.cli import main
from headmotion.features.vad import speaking_mask
from headmotion.io import load_audio, load_motion, save_audio, save_motion
from headmotion.rotations import rotvec_to_euler

pytestmark = [pytest.mark.shared, pytest.mark.slow]


def _take(shared_data):
    d = shared_data / "mocap_speech" / "zeggs"
    bvh, wav = d / "067_Speech_2_x_1_0.bvh", d / "067_Speech_2_x_1_0.wav"
    if not (bvh.exists() and wav.exists()):
        pytest.skip(f"{d} lacks the ZEGGS BVH + wav pair")
    return bvh, wav


def pause_bounds(audio, fps, n_frames, k):
    """Frame indices cutting the take into ``k`` parts, each cut in the middle of a pause (a run
    of ≥ 0.2 s without speech) nearest to an equal split."""
    speak = speaking_mask(audio, fps=fps, n_frames=n_frames)
    d = np.diff(np.concatenate([[1], speak.astype(int), [1]]))
    starts, stops = np.flatnonzero(d == -1), np.flatnonzero(d == 1)
    mids = np.array([(a + b) // 2 for a, b in zip(starts, stops) if b - a >= 0.2 * fps and 0 < a and b < n_frames])
    assert len(mids) >= k - 1, f"only {len(mids)} pauses found"
    cuts = sorted({int(mids[np.argmin(np.abs(mids - n_frames * j / k))]) for j in range(1, k)})
    return [0] + cuts + [n_frames]


def _split(shared_data, out, k=4):
    bvh, wav = _take(shared_data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        motion = load_motion(bvh)
    audio = load_audio(wav, sample_rate=16000)
    bounds = pause_bounds(audio, motion.fps, len(motion), k)
    parts = []
    for j, (a, b) in enumerate(zip(bounds[:-1], bounds[1:]), start=1):
        m = motion.slice_frames(a, b)
        s = audio.slice_seconds(a / motion.fps, b / motion.fps)
        parts.append((f"zeggs_{j}", m, s))
    return motion, bounds, parts


def _train_evaluate(corpus_dir, tmp_path):
    assert main(["corpus", "check", str(corpus_dir)]) == 0
    model = tmp_path / "tws.hmz"
    assert main(["train", str(corpus_dir), "--system", "tws-hier", "-o", str(model), "--seed", "0"]) == 0
    assert model.stat().st_size > 1000
    rep = tmp_path / "report"
    assert main(["evaluate", str(corpus_dir), "--systems", "tws-hier,ground-truth,shaped-noise", "-o", str(rep),
                 "--protocol", "loo", "--shifts", "20", "--no-figures", "--feature-table", "none"]) == 0
    rows = list(csv.DictReader(open(rep / "metrics.csv")))
    return rows


def _fcca(rows, system, metric="fcca"):
    """Per held-out recording, the metric of ``system`` (metrics.csv is long: system, recording,
    metric, value)."""
    return [float(r["value"]) for r in rows if r["system"] == system and r["metric"] == metric]


def test_zeggs_bvh_wav_import_train_evaluate(shared_data, tmp_path):
    bvh, wav = _take(shared_data)
    # the whole take imports as one recording of 68.8 s
    whole = tmp_path / "whole"
    assert main(["corpus", "import", str(bvh), str(wav), "-o", str(whole), "--speaker", "zeggs_f"]) == 0
    assert main(["corpus", "check", str(whole)]) == 0
    # folds at pauses
    motion, bounds, parts = _split(shared_data, tmp_path)
    assert len(parts) == 4 and all(b - a > 10 * motion.fps for a, b in zip(bounds[:-1], bounds[1:]))
    src = tmp_path / "parts"
    src.mkdir()
    files = []
    for rid, m, s in parts:
        save_motion(m, src / f"{rid}.bvh")
        save_audio(s, src / f"{rid}.wav")
        files += [str(src / f"{rid}.bvh"), str(src / f"{rid}.wav")]
    corpus_dir = tmp_path / "corpus"
    assert main(["corpus", "import", *files, "-o", str(corpus_dir), "--speaker", "zeggs_f"]) == 0
    rows = _train_evaluate(corpus_dir, tmp_path)
    tws = _fcca(rows, "tws-hier")
    gt = _fcca(rows, "ground-truth")
    assert len(tws) == 4 and len(gt) == 4 and np.all(np.isfinite(tws)) and np.all(np.isfinite(gt))
    # the real motion is coupled to its own speech well above chance (known answer for the pair)
    assert np.mean(gt) > 2 * np.mean(_fcca(rows, "ground-truth", "fcca_null_mean"))


def _write_openface(path, motion, *, failed=()):
    """Head motion written as OpenFace 2.x FeatureExtraction output (camera axes: pose_R* are
    intrinsic XYZ angles of C R C, C = diag(1, −1, −1); timestamps with 3 decimals)."""
    ang = rotvec_to_euler(motion.rotvec, "XYZ") * np.array([1.0, -1.0, -1.0])
    cols = ["frame", "face_id", "timestamp", "confidence", "success", "pose_Tx", "pose_Ty", "pose_Tz",
            "pose_Rx", "pose_Ry", "pose_Rz"]
    lines = [", ".join(cols)]
    for i, (rx, ry, rz) in enumerate(ang):
        bad = i in failed
        lines.append(", ".join([str(i + 1), "0", f"{i / motion.fps:.3f}", "0.000" if bad else "0.980",
                                "0" if bad else "1", "0", "0", "0" if bad else "600.0",
                                *(("0", "0", "0") if bad else (f"{rx:.3f}", f"{ry:.3f}", f"{rz:.3f}"))]))
    path.write_text("\n".join(lines) + "\n")


def test_openface_csvs_with_wavs_train_and_evaluate(shared_data, tmp_path):
    motion, bounds, parts = _split(shared_data, tmp_path)
    src = tmp_path / "of"
    src.mkdir()
    files = []
    for j, (rid, m, s) in enumerate(parts):
        _write_openface(src / f"{rid}.csv", m, failed=set(range(50 + j, 54 + j)))
        save_audio(s, src / f"{rid}.wav")
        files += [str(src / f"{rid}.csv"), str(src / f"{rid}.wav")]
        back = load_motion(src / f"{rid}.csv")
        assert back.fps == 30.0 and len(back) == len(m)
        assert back.meta["gaps"]["filled_frames"] == 4
        # away from the failed frames, the angles come back within the 3-decimal rounding
        ok = np.ones(len(m), bool)
        ok[45 + j:60 + j] = False
        assert np.abs(back.rotvec[ok] - m.rotvec[ok]).max() < 2e-3
    corpus_dir = tmp_path / "corpus_of"
    assert main(["corpus", "import", *files, "-o", str(corpus_dir), "--speaker", "zeggs_f"]) == 0
    rows = _train_evaluate(corpus_dir, tmp_path)
    assert len(_fcca(rows, "tws-hier")) == 4
