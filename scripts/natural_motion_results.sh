#!/bin/sh
# Reproduces the targets table of docs/natural_motion_results.md (issue 14).
# Needs the talking-video corpus (python scripts/build_real_corpus.py) and ../shared/data.
# About 60 min on 2 busy cores (the DNN systems' training dominates); OUT defaults to /tmp/natural_motion.
set -e
export PYTHONPATH="${PYTHONPATH:-src}"
V="${V:-$HOME/.cache/headmotion/corpus/talking_video}"
OUT="${OUT:-/tmp/natural_motion}"
ALL=tws-basic,tws-hier,le2012,mfcc-dnn,cccae,ae-dnn,f0e-dnn,fbank-dnn,wav-dnn
CANDIDATES="${CANDIDATES:-tws-basic,tws-hier,le2012,mfcc-dnn,cccae}"
mkdir -p "$OUT"

# video corpus without mead_lrs3 (non-commercial), recordings >= 4 s, 3 speaker-disjoint folds
nice python -m headmotion evaluate "$V" --exclude mead_lrs3 --min-seconds 4 --protocol speakers \
  --speaker-folds 3 --systems shifted,still,$ALL --seed 0 --shifts 100 --feature-table none -j 2 -o "$OUT/video_s0"
# second seed (other speaker folds, training and synthesis seeds) for the candidates
nice python -m headmotion evaluate "$V" --exclude mead_lrs3 --min-seconds 4 --protocol speakers \
  --speaker-folds 3 --systems shifted,still,$CANDIDATES --seed 1 --shifts 100 --feature-table none -j 2 -o "$OUT/video_s1"

# the ZEGGS mocap take in 4 folds cut at pauses (leave one fold out)
Z=../shared/data/mocap_speech/zeggs/067_Speech_2_x_1_0
rm -rf "$OUT/zeggs_corpus"
python -m headmotion corpus import $Z.bvh $Z.wav -o "$OUT/zeggs_corpus" --speaker zeggs --task mocap
nice python -m headmotion evaluate "$OUT/zeggs_corpus" --folds-at-pauses 4 --systems shifted,still,$ALL --seed 0 \
  --shifts 100 --feature-table none -o "$OUT/zeggs_s0"

python scripts/targets_table.py video_s0="$OUT/video_s0" video_s1="$OUT/video_s1" zeggs="$OUT/zeggs_s0" \
  -o "$OUT/targets.md"
