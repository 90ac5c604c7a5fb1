#!/bin/bash
# CartPole as the sequence's first task (d_max 8 = the thesis sequence's padding): reproduces the
# first column of a full run bit for bit (pnn seed 1: 258.6, 40,252 steps). Issue 21 testbed.
cd /work/main
N=$1; V=$2; shift 2
SETS=()
case $N in
  base) ;;
  ve10) SETS=(--set eval.validation_every=10) ;;
  ve5) SETS=(--set eval.validation_every=5) ;;
  dq) SETS=(--set dqn.double_q=true) ;;
  tau002) SETS=(--set dqn.tau=0.002) ;;
  clip1) SETS=(--set dqn.grad_clip=1.0) ;;
  clip3) SETS=(--set dqn.grad_clip=3.0) ;;
  dqve10) SETS=(--set dqn.double_q=true --set eval.validation_every=10) ;;
esac
for s in 0 1 2 3 4; do
  d=runs/cp_testbed/${N}_${V}__s$s
  [ -f $d/summary.json ] && continue
  .venv/bin/evodevo biarm train --variant $V --tasks CartPole-v1 --seed $s --set network.d_max=8 "${SETS[@]}" --quiet --out $d > $d.log 2>&1
done
