#!/bin/bash
# Full thesis sequence, default protocol + dqn.per_task.CartPole-v1.grad_clip=1.0 (issue 21
# candidate: the clip that stops CartPole's collapse, on CartPole only; MountainCar keeps 10).
# Each lane claims the next unclaimed run (mkdir is atomic); a killed run resumes from its
# checkpoint when the lane is started again (clear runs/pt_full/claims first).
cd /work/main
for r in pnn:3 pnn:1 biarm:0 pnn:0 biarm:1 pnn:2 biarm:2 pnn:4 biarm:3 biarm:4; do
  V=${r%:*}; s=${r#*:}; d=runs/pt_full/runs/${V}__s$s
  [ -f $d/summary.json ] && continue
  mkdir runs/pt_full/claims/${V}_$s 2>/dev/null || continue
  mkdir -p runs/pt_full/runs
  R=""; [ -d $d ] && R="--resume"
  ( time .venv/bin/evodevo biarm train $R --variant $V --seed $s --protocol default --set eval.episodes=20 --set dqn.per_task.CartPole-v1.grad_clip=1.0 --quiet --out $d ) >> $d.log 2>&1
done
