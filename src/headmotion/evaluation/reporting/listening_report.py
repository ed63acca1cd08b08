"""The listening ruler's report (``headmotion evaluate-listening``): its table and its figure.

* :func:`listening_table` — a Markdown table: one row per model, group of conversations (voices,
  condition) and head, with nods per minute of heard speech, the share of nods that follow a cue
  against shifted nods, ``p`` per seed and pooled, and the speed in the other's turns;
* :func:`conversation_figure` — one conversation: the other party's pitch as Praat reads it, the
  cues the ruler finds, the head's pitch with and without listening, the nods read from the motion.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: the rows' verdict: every seed's p below this
P_TARGET = 0.05


def listening_table(rows_by_model: dict, *, pauses=None) -> str:
    """Markdown table of :class:`~headmotion.evaluation.protocol.listening.ListeningRow` lists by model;
    ``pauses`` (10th, 50th, 90th percentile °/s of the recorded pauses) adds the speeds' range."""
    out = ["| model | voices | condition | head | conversations | heard (s) | cues/min | nods/min | "
           "follow a cue | shifted | p per seed | pooled p | every seed p < 0.05 | speed (°/s) |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for model, rows in rows_by_model.items():
        for r in rows:
            res = r.result
            every = all(p < P_TARGET for p in res.p)
            out.append(f"| {model} | {r.voices} | {r.condition} | {r.head} | {r.conversations} | {r.heard_s:.0f} | "
                       f"{r.cues_per_min:.1f} | {r.nods_per_min:.1f} | {res.pooled_share:.2f} | "
                       f"{res.pooled_shifted:.2f} | {' / '.join(f'{p:.3f}' for p in res.p)} | {res.pooled_p:.3f} | "
                       f"{'yes' if every else 'no'} | {np.mean(r.speed):.1f} |")
    text = "\n".join(out) + "\n"
    if pauses is not None:
        text += (f"\nRecorded pauses of the corpus: {pauses[0]:.1f}–{pauses[2]:.1f} °/s (10th–90th percentile), "
                 f"median {pauses[1]:.1f}.\n")
    return text


def conversation_figure(conv, listening, waiting, cues, nods, path, *, seconds: float = 40.0) -> Path:
    """The figure of one conversation (module docstring) over its first ``seconds``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import parselmouth
    from scipy.signal import butter, sosfiltfilt

    from ..measures.backchannel import NOD_LOWPASS_HZ

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(12, 5.5), sharex=True)
    pitch = parselmouth.Sound(conv.heard.samples.astype(np.float64), conv.heard.sample_rate).to_pitch(time_step=0.01)
    f0 = pitch.selected_array["frequency"]
    f0[f0 == 0] = np.nan
    top.plot(pitch.xs(), f0, ".", ms=2, color="tab:blue", label="the other's pitch (Praat)")
    for k, c in enumerate(cues):
        top.axvline(c, color="k", lw=0.8, label="cue (Ward & Tsukahara)" if k == 0 else None)
    top.set_ylabel("Hz")
    top.legend(loc="upper right", fontsize=8)
    for m, label, colour in ((waiting, "not listening", "tab:gray"), (listening, "listening", "tab:orange")):
        p = m.as_pitch_yaw_roll(degrees=True)[:, 0]
        p = sosfiltfilt(butter(4, NOD_LOWPASS_HZ, fs=m.fps, output="sos"), p)
        bottom.plot(np.arange(len(p)) / m.fps, p, color=colour, label=f"head pitch, {label}")
    for k, n in enumerate(nods):
        bottom.axvline(n, color="tab:red", lw=0.8, ls="--", label="nod read from the motion" if k == 0 else None)
    for ax in (top, bottom):
        for k, (a, b) in enumerate(conv.spans):
            ax.axvspan(a, b, color="gold", alpha=0.15, label="the other speaks" if k == 0 and ax is bottom else None)
    bottom.set_ylabel("pitch (°, nose down +)")
    bottom.set_xlabel("s")
    bottom.legend(loc="upper right", fontsize=8)
    bottom.set_xlim(0, min(seconds, conv.own.duration))
    top.set_title(f"{conv.name} ({conv.condition})")
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


__all__ = ["listening_table", "conversation_figure", "P_TARGET"]
