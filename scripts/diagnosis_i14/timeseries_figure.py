"""Issue 14: a real recording next to the default model before / with sampling + pauses and the
held-out tws-hier prototype (pitch, yaw, roll over 20 s).  Run from the repository root with
PYTHONPATH=src after proto_tws.py has saved its predictions."""
import sys; sys.path.insert(0, 'scripts')
import numpy as np, warnings; warnings.filterwarnings('ignore')
import matplotlib; matplotlib.use('Agg'); import matplotlib.pyplot as plt
from realism_report import video_corpus, HOME, at_rate
from headmotion.systems.base import load_model
from headmotion.evaluation import realism as R
from headmotion.motion.pauses import settle_in_pauses
rid = sys.argv[1] if len(sys.argv) > 1 else 'dfrf_french'
rec = [r for r in video_corpus(HOME / 'corpus/talking_video') if r.id == rid][0]
f = rec.motion.fps; n = min(len(rec.motion), int(20 * f))
mask = R.speech_mask_for(rec.audio, rec.motion)
dm = load_model('src/headmotion/data/default_model.hmz')
before = at_rate(dm.predict(rec.audio, seed=0), f, len(rec.motion))
dm.stochastic = 'params'
samp = settle_in_pauses(at_rate(dm.predict(rec.audio, seed=0), f, len(rec.motion)), mask, fps=f, idle=0.4)
proto = np.load(HOME / 'diagnosis_i14/video_tws-hier_params+h0.5+p0.4.npz')[rid]
t = np.arange(n) / f
fig, axes = plt.subplots(3, 1, figsize=(13, 8), sharex=True)
for j, ax in enumerate(axes):
    from headmotion.features.vad import _runs
    for a, b in _runs(~mask[:n]):
        ax.axvspan(a / f, b / f, color='0.92', lw=0)
    ax.plot(t, np.degrees(rec.motion.rotvec[:n, j] - rec.motion.rotvec[:, j].mean()), 'k', lw=2, label='recorded head (video)')
    ax.plot(t, np.degrees(before[:n, j] - before[:, j].mean()), color='tab:red', lw=1, label='default today (deterministic)')
    ax.plot(t, np.degrees(samp[:n, j] - samp[:, j].mean()), color='tab:blue', lw=1, label='default, stochastic=params + pauses 0.4')
    ax.plot(t, np.degrees(proto[:n, j] - proto[:, j].mean()), color='tab:green', lw=1, label='tws-hier held-out, params + min swing 0.5° + pauses')
    ax.set_ylabel(['pitch', 'yaw', 'roll'][j] + ' (°)')
axes[0].legend(fontsize=8, ncol=2, loc='upper right')
axes[-1].set_xlabel(f's ({rid}; grey = no speech)')
fig.tight_layout(); fig.savefig(f'docs/figures/before_after_{rid}.png', dpi=100)
print('wrote', f'docs/figures/before_after_{rid}.png')
