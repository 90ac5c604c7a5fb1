#!/bin/bash
# MountainCar-v0 alone, d_max 8 (the sequence's padding), 800 episodes: does a protocol change
# keep MountainCar's exploration? (issue 21; the sequence's MountainCar also reads laterals).
cd /work/main
N=$1; V=$2; shift 2
SETS=()
case $N in
  base) ;;
  clip1) SETS=(--set dqn.grad_clip=1.0) ;;
  clip3) SETS=(--set dqn.grad_clip=3.0) ;;
  dq) SETS=(--set dqn.double_q=true) ;;
esac
for s in "$@"; do
  d=runs/mc_testbed/${N}_${V}__s$s
  [ -f $d/summary.json ] && continue
  .venv/bin/evodevo biarm train --variant $V --tasks MountainCar-v0 --seed $s --set network.d_max=8 "${SETS[@]}" --quiet --out $d > $d.log 2>&1
done
