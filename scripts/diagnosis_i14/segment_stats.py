"""Issue 14 diagnosis probe (seg); run from the repository root with PYTHONPATH=src."""
import sys; sys.path.insert(0,'scripts')
import numpy as np
from realism_report import video_corpus, HOME, ZEGGS
from headmotion.motion.segmentation import segment
from headmotion.io import load_motion
def stats(motions, name, fps=100.0):
    d=[[],[],[]]; a=[[],[],[]]
    for m in motions:
        m = m.resample(fps)
        for j in range(3):
            s=segment(m.rotvec[:,j], fps=fps)
            d[j]+=list(s.durations/fps); a[j]+=list(np.abs(s.amplitudes)*180/np.pi)
    print(name, ' '.join(f"ax{j}: n={len(d[j])} dur med {np.median(d[j]):.3f}s (p10 {np.percentile(d[j],10):.2f}, p90 {np.percentile(d[j],90):.2f}) amp med {np.median(a[j]):.2f}°" for j in range(3)))
    return d,a
v=video_corpus(HOME/'corpus/talking_video')
stats([r.motion for r in v],'video@100')
stats([load_motion(ZEGGS.with_suffix('.bvh'))],'zeggs@100')
# jitter level: SD of second difference at native rate
j=[np.std(np.diff(r.motion.rotvec,n=2,axis=0),axis=0)*180/np.pi for r in v]
print('video jitter (SD of 2nd diff, deg/frame^2):', np.median(j,axis=0).round(3))
z=load_motion(ZEGGS.with_suffix('.bvh'))
print('zeggs SD 2nd diff', (np.std(np.diff(z.rotvec,n=2,axis=0),axis=0)*180/np.pi).round(3))
