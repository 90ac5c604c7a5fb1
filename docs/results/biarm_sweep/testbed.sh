#!/bin/bash
# One task of the thesis sequence alone, with the sequence's padding (d_max 8), PNN or BIARM,
# under a named change of the default protocol (issue 21). Usage, from anywhere:
#   docs/results/biarm_sweep/testbed.sh TASK NAME VARIANT [SEEDS...]   (seeds default 0-4)
# CartPole-v1 gives the first column of a full run bit for bit (runs/cp_testbed/); for
# MountainCar-v0 (runs/mc_testbed/) it is the task without the earlier columns.
set -u
cd "$(dirname "$0")/../../.."
TASK=$1; N=$2; V=$3; shift 3
SEEDS=("$@"); [ ${#SEEDS[@]} -eq 0 ] && SEEDS=(0 1 2 3 4)
case $TASK in CartPole-v1) G=cp_testbed ;; MountainCar-v0) G=mc_testbed ;; *) G=testbed_$TASK ;; esac
case $N in
  base) SETS=() ;;
  ve10) SETS=(--set eval.validation_every=10) ;;
  ve5) SETS=(--set eval.validation_every=5) ;;
  dq) SETS=(--set dqn.double_q=true) ;;
  tau002) SETS=(--set dqn.tau=0.002) ;;
  clip1) SETS=(--set dqn.grad_clip=1.0) ;;
  clip3) SETS=(--set dqn.grad_clip=3.0) ;;
  *) echo "unknown change $N (base ve10 ve5 dq tau002 clip1 clip3)" >&2; exit 2 ;;
esac
mkdir -p runs/$G
for s in "${SEEDS[@]}"; do
  d=runs/$G/${N}_${V}__s$s
  [ -f $d/summary.json ] && continue
  .venv/bin/evodevo biarm train --variant $V --tasks $TASK --seed $s --set network.d_max=8 \
      ${SETS[@]+"${SETS[@]}"} --quiet --out $d > $d.log 2>&1
done
