#!/bin/bash
# full-sequence runs under the default protocol with eval.validation_episodes=20 (issue 21)
cd /work/main
V=$1; shift
for s in "$@"; do
  [ -f runs/val20_full/${V}__s$s/summary.json ] && continue
  R=""; [ -d runs/val20_full/${V}__s$s ] && R="--resume"
  ( time .venv/bin/evodevo biarm train $R --variant $V --seed $s --protocol default --set eval.episodes=20 --set eval.validation_episodes=20 --quiet --out runs/val20_full/${V}__s$s ) >> runs/val20_full/${V}__s$s.log 2>&1
done
