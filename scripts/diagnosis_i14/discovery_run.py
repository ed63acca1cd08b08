"""Issue 14: template discovery on one real speaker (feifeili, andrew) or ZEGGS; usage: discovery_run.py SPEAKER|zeggs MIN_SWING_DEG OUT_DIR."""
import sys, time, json; sys.path.insert(0,'scripts')
import warnings; warnings.filterwarnings('ignore')
from headmotion.corpus import Corpus
from headmotion.motion.discovery import analyse
from realism_report import HOME, ZEGGS
from headmotion.io import load_motion
which=sys.argv[1]; swing=float(sys.argv[2]); out=sys.argv[3]
if which=='zeggs': ms=[load_motion(ZEGGS.with_suffix('.bvh'))]
else: ms=[r.motion for r in Corpus.load(HOME/'corpus/talking_video') if r.speaker==which]
print(which, [round(m.duration,1) for m in ms])
t=time.time()
res=analyse(ms, out, n_initialisers=(20,40,80), n_sets=3, n_init_main=120, min_swing_deg=swing)
print(json.dumps({k:v for k,v in res.items() if k!='bic'}, indent=None)[:1500]); print(time.time()-t,'s')
