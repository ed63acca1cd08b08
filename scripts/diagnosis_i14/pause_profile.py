"""Issue 14 diagnosis probe (pauses); run from the repository root with PYTHONPATH=src."""
import sys; sys.path.insert(0,'scripts')
import numpy as np
from realism_report import video_corpus, HOME
from headmotion.evaluation import realism as R
from headmotion.features.vad import _runs
bins=[(0,0.25),(0.25,0.5),(0.5,1.0),(1.0,2.0),(2.0,4.0)]
def profile(recs):
    acc={b:[] for b in bins}; post={b:[] for b in [(0,0.25),(0.25,0.5),(0.5,1.0)]}
    dist_p=[];dist_s=[]; ratios=[]
    for r in recs:
        m=r.motion; f=m.fps; mask=R.speech_mask_for(r.audio,m)
        sp=np.r_[R.speed(m),0]
        ms=sp[mask].mean()
        x=m.rotvec*R.DEG; mu=x.mean(0); d=np.linalg.norm(x-mu,axis=1)
        for a,b in _runs(~mask):
            if b-a < 0.5*f: continue
            for lo,hi in bins:
                i0,i1=a+int(lo*f),min(b,a+int(hi*f))
                if i1>i0: acc[(lo,hi)].append(sp[i0:i1].mean()/ms)
            for lo,hi in post:
                i0,i1=b+int(lo*f),min(len(sp),b+int(hi*f))
                if i1>i0: post[(lo,hi)].append(sp[i0:i1].mean()/ms)
            dist_p.append(d[a:b].mean())
        dist_s.append(d[mask].mean())
        ratios.append(R.pause_speed_ratio(m,mask))
    print(' speed in pauses / mean speech speed, by time since pause onset:')
    for k,v in acc.items(): print(f'   {k}: median {np.median(v):.2f} (n={len(v)})' if v else f'   {k}: -')
    print(' after speech resumes:', {k:round(float(np.median(v)),2) for k,v in post.items() if v})
    print(f' distance from mean pose: pauses {np.median(dist_p):.2f} deg, speech {np.median(dist_s):.2f} deg')
    rr=np.array(ratios); rr=rr[np.isfinite(rr)]
    print(f' pause/speech speed ratio per recording: median {np.median(rr):.2f} IQR {np.percentile(rr,25):.2f}-{np.percentile(rr,75):.2f} n={len(rr)}')
print('ZEGGS (whole take):'); 
from headmotion.corpus import Recording
from headmotion.io import load_motion
from headmotion.io.audio import load_audio
from realism_report import ZEGGS
z=Recording.aligned('z','z','m',load_audio(ZEGGS.with_suffix('.wav')),load_motion(ZEGGS.with_suffix('.bvh')))
profile([z])
m=z.motion; f=m.fps; x=m.rotvec*R.DEG; sp=R.speed(m)
print(' ZEGGS opening silence 0-2.4 s: speed', sp[:int(2.4*f)].mean().round(1), 'speech mean', sp[R.speech_mask_for(z.audio,m)[1:]].mean().round(1))
print('video corpus (without mead_lrs3):'); profile(video_corpus(HOME/'corpus/talking_video'))
