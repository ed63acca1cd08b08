"""Prototype fixes for the template-warping systems on real data (issue 14 diagnosis; not shipped).

Kept as the record of the diagnosis: it patches the module layout before the system contract
refactor (``systems/tws_common.py``), so it runs on commit 80da627 (``git worktree add /tmp/diag
80da627``), not on today's code, where these fixes are the tws systems' own parameters
(``min_swing_deg``, ``soft_limit``, ``idle``, ``stochastic``; ``scripts/tws_realism.py``).

Monkeypatches headmotion.systems.tws_common (segmentation with a minimum swing, soft limits) and
post-processes with headmotion.motion.pauses.  Usage (from the repository root, PYTHONPATH=src):

    python scripts/diagnosis_i14/proto_tws.py video|zeggs tws-hier,tws-basic params,params+h0.5+p0.4+soft

Variant tokens joined by '+': none|params|both (stochastic mode), hX (min swing X degrees),
pX (pauses idle level X), soft (amplitude shrinks towards the range edge: pull to the mean).
"""
import sys, time, warnings; sys.path.insert(0,'scripts')
warnings.filterwarnings('ignore')
import numpy as np
from realism_report import zeggs_folds, video_corpus, HOME, speaker_folds, at_rate, context, limits_of
from headmotion.corpus import Corpus
from headmotion.evaluation import realism as R
from headmotion.systems import create
import headmotion.systems.tws_common as TC
from headmotion.motion.pauses import settle_in_pauses
from headmotion.motion.segmentation import segment_axis as _seg
ORIG = TC.segment_axis
ORIG_CLIP = TC.Limits.clip
def soft_clip(self, j, d, a, c, sign, fps):
    # pull back towards the mean pose: the amplitude of a move away from the mean shrinks
    # linearly to 0 as the start approaches the training range's edge on that side
    mu = self.mean[j]
    edge = (self.hi[j] if sign > 0 else self.lo[j]) - mu
    away = (c - mu) / edge if abs(edge) > 1e-12 else 0.0
    if away > 0:
        a = a * max(0.0, 1.0 - away)
    return ORIG_CLIP(self, j, d, a, c, sign, fps)
class _ScaledRng:
    """Sampling temperature: the regression noise drawn with standard_normal is scaled."""
    def __init__(self, rng, temp):
        self._rng, self._temp = rng, temp
    def standard_normal(self, *a, **k):
        return self._temp * self._rng.standard_normal(*a, **k)
    def __getattr__(self, n):
        return getattr(self._rng, n)
import headmotion.systems.tws_hier as _TH
_ORIG_CHOOSE = _TH.TwsHier._choose
def _wrap_choose(temp):
    if temp == 1.0:
        return _ORIG_CHOOSE
    def choose(self, j, tau, state, F, t, rng):
        return _ORIG_CHOOSE(self, j, tau, state, F, t, _ScaledRng(rng, temp))
    return choose
which = sys.argv[1]  # video | zeggs
systems = sys.argv[2].split(',')
variants = sys.argv[3].split(',')
if which=='video':
    recs=[r for r in video_corpus(HOME/'corpus/talking_video') if r.duration>=4]; folds=speaker_folds(recs,2)
else:
    recs=zeggs_folds(4); folds=[[i] for i in range(len(recs))]
ctx={}
KEYS=['fcca_excess_seed1','fcca_p_pooled_seed1','band_1.5_4','band_1.5_4_ref','spectral_l1','sd_ratio_pitch','sd_ratio_yaw','sd_ratio_roll','speed_hellinger','limit_cycle','limit_cycle_ref','saturation','pause_ratio','pause_ratio_ref','fcca_excess','fcca_p_pooled','diversity']
def variant(v):
    d=dict(stoch='none', hyst=None, pause=None)
    for part in v.split('+'):
        if part in ('none','params','both','cluster','class'): d['stoch']=part
        elif part.startswith('h'): d['hyst']=float(part[1:])
        elif part.startswith('p'): d['pause']=float(part[1:])
        elif part=='soft': d['soft']=True
        elif part.startswith('t'): d['temp']=float(part[1:])
    return d
for sysname in systems:
    for v in variants:
        cfg=variant(v); t=time.time()
        if cfg['hyst'] is not None:
            delta=np.radians(cfg['hyst'])
            TC.segment_axis=lambda x,*,fps,min_segment=None,smoothed=False,_d=delta: _seg(x,fps=fps,min_segment=min_segment,smoothed=smoothed,min_swing=_d)
        else:
            TC.segment_axis=ORIG
        TC.Limits.clip = soft_clip if cfg.get('soft') else ORIG_CLIP
        import headmotion.systems.tws_hier as TH
        TH.TwsHier._choose = _wrap_choose(cfg.get('temp', 1.0))
        kw={}
        st=cfg['stoch']
        if sysname=='tws-basic': kw['stochastic']={'none':'none','params':'params','both':'both','class':'class'}.get(st,'none')
        else: kw['stochastic']=st
        preds={}
        for test in folds:
            train=[recs[i] for i in range(len(recs)) if i not in test]
            m=create(sysname,features='f0e',fps=100.0,**kw).fit(Corpus(train))
            for i in test:
                r=recs[i]; mask=context(r,ctx)[0]
                ps=[at_rate(m.predict(r.audio,seed=s),r.motion.fps,len(r.motion)) for s in range(2)]
                if cfg['pause'] is not None: ps=[settle_in_pauses(p,mask,fps=r.motion.fps,idle=cfg['pause']) for p in ps]
                preds[r.id]=ps
        (HOME / "diagnosis_i14").mkdir(parents=True, exist_ok=True)
        np.savez_compressed(f"{HOME}/diagnosis_i14/{which}_{sysname}_{v}.npz", **{r.id: preds[r.id][0] for r in recs})
        masks,ons,feats=zip(*[context(r,ctx) for r in recs])
        rows=R.realism_rows({v:[preds[r.id][0] for r in recs]},[r.motion for r in recs],speech_masks=masks,onsets=ons,features=feats,limits_deg={v:limits_of(recs)},samples={v:[preds[r.id] for r in recs]},n_shifts=100)
        s=rows[-1]
        rows1=R.realism_rows({v:[preds[r.id][1] for r in recs]},[r.motion for r in recs],features=feats,n_shifts=100)
        s['fcca_excess_seed1']=rows1[-1]['fcca_excess']; s['fcca_p_pooled_seed1']=rows1[-1]['fcca_p_pooled']
        print(f"{which} {sysname} {v}: "+' '.join(f"{k}={s.get(k,np.nan):.3g}" for k in KEYS)+f" ({time.time()-t:.0f}s)",flush=True)
