#!/bin/bash
# A/B: the same synthetic clip made and tracked by the base revision and by the working
# tree, in the same folder (paths equal); every output compared byte for byte, JSON files
# compared with their wall-clock "seconds" fields removed.

# Usage: BASE=DIR_OF_BASE_CHECKOUT NEW=DIR_OF_NEW_CHECKOUT benchmarks/tracking_ab.sh
BASE=${BASE:?a checkout of the base revision, e.g. git worktree add --detach /tmp/base e33dc8e}
NEW=${NEW:-$(cd "$(dirname "$0")/.." && pwd)}
PY=${PY:-$NEW/.venv/bin/python}
WORK=${WORK:-$(mktemp -d)}
for side in base new; do
  if [ $side = base ]; then SRC=$BASE/src; else SRC=$NEW/src; fi
  D=$WORK/run; rm -rf $D; mkdir -p $D
  PYTHONPATH=$SRC $PY -m thermoswarm.tracking.synth $D/clip --seed 3 --set n_frames=60 --set width=640 --set height=480 --set n_ants=8 > $D/synth.log
  PYTHONPATH=$SRC $PY -m thermoswarm track $D/clip/video.mp4 --out $D/trk > $D/track.log 2>&1; echo "rc $?" >> $D/track.log
  PYTHONPATH=$SRC $PY -m thermoswarm track --detections $D/clip/gt/gt.txt --fps 10 --out $D/trk_det > $D/trkdet.log 2>&1; echo "rc $?" >> $D/trkdet.log
  PYTHONPATH=$SRC $PY -m thermoswarm detect $D/clip/video.mp4 --out $D/det > $D/det.log 2>&1; echo "rc $?" >> $D/det.log
  rm -rf $WORK/$side; mv $D $WORK/$side
done
cd $WORK
n=0; d=0
for f in $(cd base && find . -type f | sort); do
  n=$((n+1))
  if [[ $f == *.json ]]; then
    same=$($PY -c "import json,sys
def s(o):
    if isinstance(o,dict): return {k:s(v) for k,v in o.items() if 'second' not in k}
    if isinstance(o,list): return [s(v) for v in o]
    return o
print(s(json.load(open('base/$f')))==s(json.load(open('new/$f'))))")
  else
    cmp -s <(sed -E "s/[0-9.]+ frames\/s//" base/$f) <(sed -E "s/[0-9.]+ frames\/s//" new/$f) && same=True || same=False
  fi
  if [ "$same" = True ]; then echo "same  $f"; else echo "DIFF  $f"; d=$((d+1)); fi
done
echo "$n files, $d differ"
