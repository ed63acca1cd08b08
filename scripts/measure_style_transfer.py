#!/usr/bin/env python
"""Measure style transfer (issue 17 item 2) on real recordings: the shipped default model's output
for real speech, unstyled vs styled like a reference vs the reference itself.

    python scripts/measure_style_transfer.py [--data ../shared/data] [--corpus DIR] [--plot OUT.png]

References: the ZEGGS mocap take and talking-video recordings of the real corpus (default
~/.cache/headmotion/corpus/talking_video, built by scripts/build_real_corpus.py; skipped if
absent).  For each (speech, reference, axis) it prints the SD (deg) and the band shares
(0–0.5 / 0.5–1.5 / 1.5–4 / ≥4 Hz) before / after / of the reference, and the fraction of the
distance to the reference that remains (SD: |after − ref| / |before − ref|; shares: the same with
L1 distances).  The issue asks for ≤ 0.5.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from headmotion.io.audio import load_audio
from headmotion.motion.style import BAND_EDGES, apply_style, load_style_reference, style_profile
from headmotion.systems.base import load_model

ROOT = Path(__file__).resolve().parents[1]
SPEECH = ("speech/jfk.flac", "speech/RD_Radio31_000.wav", "mocap_speech/zeggs/067_Speech_2_x_1_0.wav")
VIDEO_REFS = ("dfrf_french", "sadtalker_WDA_KatieHill_000", "styletalk_feifeili_clip1",
              "mimictalk_German_20s", "pc_avs_Audio_Source_00086")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data")
    ap.add_argument("--corpus", type=Path, default=Path.home() / ".cache/headmotion/corpus/talking_video")
    ap.add_argument("--plot", type=Path, default=None, help="spectra of the first speech, every reference")
    args = ap.parse_args()
    model = load_model(ROOT / "src" / "headmotion" / "data" / "default_model.hmz")
    refs = {"zeggs": args.data / "mocap_speech" / "zeggs" / "067_Speech_2_x_1_0.bvh"}
    refs.update({r: args.corpus / f"{r}.npz" for r in VIDEO_REFS if (args.corpus / f"{r}.npz").exists()})
    refs = {k: load_style_reference(p) for k, p in refs.items()}
    worst_sd = worst_sh = 0.0
    print("speech | reference | axis | SD before/after/ref (deg) | shares before / after / ref | "
          "remaining SD, shares")
    first = None
    for sp in SPEECH:
        cand = model.predict(load_audio(args.data / sp, sample_rate=model.sample_rate_))
        first = first or (Path(sp).stem, cand)
        b = style_profile(cand)
        for name, ref in refs.items():
            a, r = style_profile(apply_style(cand, ref)), style_profile(ref)
            for ax, axn in enumerate(("pitch", "yaw", "roll")):
                rem_sd = abs(a.sd[ax] - r.sd[ax]) / max(abs(b.sd[ax] - r.sd[ax]), 1e-12)
                rem_sh = (np.abs(a.shares[ax] - r.shares[ax]).sum()
                          / max(np.abs(b.shares[ax] - r.shares[ax]).sum(), 1e-12))
                worst_sd, worst_sh = max(worst_sd, rem_sd), max(worst_sh, rem_sh)
                f = lambda v: "[" + " ".join(f"{x:.2f}" for x in v) + "]"  # noqa: E731
                print(f"{Path(sp).stem} | {name} | {axn} | {b.sd[ax]:.2f}/{a.sd[ax]:.2f}/{r.sd[ax]:.2f} | "
                      f"{f(b.shares[ax])} / {f(a.shares[ax])} / {f(r.shares[ax])} | {rem_sd:.3f}, {rem_sh:.3f}")
    print(f"worst remaining fraction: SD {worst_sd:.3g}, shares {worst_sh:.3g} (issue: <= 0.5)")
    if args.plot:
        _plot(first, refs, args.plot)


def _plot(first, refs, out) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy import signal

    name_c, cand = first
    fig, axes = plt.subplots(len(refs), 3, figsize=(15, 3.2 * len(refs)), squeeze=False)
    for row, (name, ref) in enumerate(refs.items()):
        styled = apply_style(cand, ref)
        for ax in range(3):
            a = axes[row, ax]
            for m, lab, col in ((cand, "unstyled", "C0"), (styled, "styled", "C1"), (ref, name, "k")):
                x = m.as_pitch_yaw_roll(degrees=True)[:, ax]
                f, p = signal.welch(x - x.mean(), fs=m.fps, nperseg=min(len(x), int(8 * m.fps)))
                a.loglog(f[1:], p[1:], color=col, label=lab)
            for e in BAND_EDGES:
                a.axvline(e, color="grey", ls=":")
            a.set_xlim(0.1, 15)
            a.set_title(f"{('pitch', 'yaw', 'roll')[ax]} PSD (deg²/Hz), {name_c} → {name}", fontsize=9)
            a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=70)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
