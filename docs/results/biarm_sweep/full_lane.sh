#!/bin/bash
# One lane of a full-sequence grid (issue 21): PNN and BIARM, seeds 0-4, protocol $PROTOCOL
# (default: default) with 20 evaluation episodes plus the grid's overrides. Usage, from anywhere:
#   [PROTOCOL=v3] docs/results/biarm_sweep/full_lane.sh GRID [--set key=value ...]
# e.g. GRID pt_full with --set dqn.per_task.CartPole-v1.grad_clip=1.0 (clip1_full: --set
# dqn.grad_clip=1.0; dq_full: --set dqn.double_q=true). Runs go to runs/GRID/runs/; start two
# lanes for the 2 cores: each claims the next unclaimed run (mkdir is atomic), and a killed run
# resumes from its checkpoint when a lane is started again (clear runs/GRID/claims first).
set -u
cd "$(dirname "$0")/../../.."
G=$1; shift
mkdir -p runs/$G/runs runs/$G/claims
for r in pnn:3 pnn:1 biarm:0 pnn:0 biarm:1 pnn:2 biarm:2 pnn:4 biarm:3 biarm:4; do
  V=${r%:*}; s=${r#*:}; d=runs/$G/runs/${V}__s$s
  [ -f $d/summary.json ] && continue
  mkdir runs/$G/claims/${V}_$s 2>/dev/null || continue
  R=""; [ -d $d ] && R="--resume"
  ( time .venv/bin/evodevo biarm train $R --variant $V --seed $s --protocol ${PROTOCOL:-default} \
      --set eval.episodes=20 "$@" --quiet --out $d ) >> $d.log 2>&1
done
