"""Prototype post-processing fixes for le2012 and the DNN on cached predictions of
scripts/realism_report.py (issue 14 diagnosis; not shipped): global-variance scaling (DNN), a 4 s
running-mean detrend standing in for a pull towards the mean pose (le2012), pauses.

    python scripts/realism_report.py   # fills the cache first
    python scripts/diagnosis_i14/proto_post.py
"""
import sys; sys.path.insert(0,'scripts')
import numpy as np, warnings; warnings.filterwarnings('ignore')
from realism_report import zeggs_folds, video_corpus, speaker_folds, HOME, context, limits_of
from headmotion.evaluation import realism as R
from headmotion.motion.pauses import settle_in_pauses
from scipy.ndimage import uniform_filter1d
KEYS=['band_1.5_4','band_1.5_4_ref','spectral_l1','sd_ratio_pitch','sd_ratio_yaw','sd_ratio_roll','speed_hellinger','limit_cycle','limit_cycle_ref','saturation','pause_ratio','pause_ratio_ref','drift','drift_ref','fcca_excess','fcca_p_pooled']
ctx={}
def evaluate(tag, recs, folds, sysn, post, label):
    z=np.load(HOME/f'realism_report/{tag}_{sysn}.npz')
    preds={}
    for test in folds:
        train=[recs[i] for i in range(len(recs)) if i not in test]
        sd_train=np.vstack([r.motion.rotvec for r in train]).std(0)
        mu_train=np.vstack([r.motion.rotvec for r in train]).mean(0)
        for i in test:
            r=recs[i]; p=z[f'{r.id}_s0']; mask=context(r,ctx)[0]
            preds[r.id]=post(p, sd_train, mu_train, r.motion.fps, mask)
    masks,ons,feats=zip(*[context(r,ctx) for r in recs])
    rows=R.realism_rows({label:[preds[r.id] for r in recs]},[r.motion for r in recs],speech_masks=masks,onsets=ons,features=feats,limits_deg={label:limits_of(recs)},n_shifts=100)
    s=rows[-1]; print(f"{tag} {sysn} {label}: "+' '.join(f"{k}={s.get(k,np.nan):.3g}" for k in KEYS),flush=True)
def ident(p,sd,mu,f,m): return p
def gv(p,sd,mu,f,m):
    c=p.mean(0); s=p.std(0); g=np.minimum(sd/np.maximum(s,1e-9),6.0); return c+(p-c)*g
def gv_p(p,sd,mu,f,m): return settle_in_pauses(gv(p,sd,mu,f,m),m,fps=f,idle=0.4)
def detrend(p,sd,mu,f,m):
    w=int(4*f); lo=uniform_filter1d(p,w,axis=0,mode='nearest'); return p-lo+mu
def detrend_p(p,sd,mu,f,m): return settle_in_pauses(detrend(p,sd,mu,f,m),m,fps=f,idle=0.4)
def ou(T, f, tau, rng):
    a = np.exp(-1.0 / (tau * f)); e = rng.standard_normal((T, 3)) * np.sqrt(1 - a * a)
    x = np.zeros((T, 3)); x[0] = rng.standard_normal(3)
    for t in range(1, T):
        x[t] = a * x[t - 1] + e[t]
    return x
def gv_drift_p(p, sd, mu, f, m, slow=0.6, tau=2.0):
    c = p.mean(0); s = p.std(0)
    fast = (p - c) / np.maximum(s, 1e-9) * sd * np.sqrt(1 - slow)
    y = c + fast + ou(len(p), f, tau, np.random.default_rng(0)) * sd * np.sqrt(slow)
    return settle_in_pauses(y, m, fps=f, idle=0.4)
z=zeggs_folds(4); zf=[[i] for i in range(4)]
v=[r for r in video_corpus(HOME/'corpus/talking_video') if r.duration>=4]
ids=[r.id for r in v]
zz=np.load(HOME/'realism_report/video_mfcc-dnn.npz'); have={k.rsplit('_s',1)[0] for k in zz.files}
v=[r for r in v if r.id in have]; vf=speaker_folds(v,2)
if len(sys.argv) > 1 and sys.argv[1] == 'drift':
    for tag,recs,folds in (('zeggs',z,zf),('video',v,vf)):
        evaluate(tag,recs,folds,'mfcc-dnn',gv_drift_p,'gv+OU(tau2s,60%)+pause0.4')
    sys.exit()
for tag,recs,folds in (('zeggs',z,zf),('video',v,vf)):
    evaluate(tag,recs,folds,'mfcc-dnn',ident,'asis')
    evaluate(tag,recs,folds,'mfcc-dnn',gv,'gv')
    evaluate(tag,recs,folds,'mfcc-dnn',gv_p,'gv+pause0.4')
    evaluate(tag,recs,folds,'le2012',ident,'asis')
    evaluate(tag,recs,folds,'le2012',detrend,'detrend4s')
    evaluate(tag,recs,folds,'le2012',detrend_p,'detrend4s+pause0.4')
