"""Issue 14 diagnosis probe (fixed); run from the repository root with PYTHONPATH=src."""
import sys; sys.path.insert(0,'scripts')
import numpy as np, warnings; warnings.filterwarnings('ignore')
from headmotion.systems.base import load_model
from headmotion.io.audio import load_audio
from headmotion.motion.segmentation import segment
dm=load_model('src/headmotion/data/default_model.hmz')
au=load_audio('/work/shared/data/speech/jfk.flac',sample_rate=16000)
for st in ['none','params']:
    dm.stochastic=st
    m=dm.predict(au,seed=0)
    for j,ax in enumerate(['pitch','yaw','roll']):
        s=segment(m.rotvec[:,j],fps=m.fps)
        d=s.durations/m.fps; a=np.degrees(np.abs(s.amplitudes))
        print(st, ax, f"n={len(d)} dur mean {d.mean():.3f} CV {d.std()/d.mean():.2f} amp mean {a.mean():.2f} CV {a.std()/a.mean():.2f}")
L=dm.limits_
print('training d_mean', L.d_mean.round(3), 'a_mean deg', np.degrees(L.a_mean).round(2), 'd_max', L.d_max.round(2))
