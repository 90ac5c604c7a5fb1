#!/usr/bin/env bash
# The pre-registered experiments of docs/results/claims.md, each run by the code of the commit it
# was registered at (a git worktree per commit, beside the checkout), into this folder.
# Resumable: run it again and finished runs are skipped, interrupted ones resume from their
# checkpoints. Usage (from the repository root): bash docs/results/claims/run_experiments.sh [E1|E2 ...]
#
# Two lanes may run at once (2026-12-07: the PPO and NEAT runs use one core of two): every run,
# chunk of seeds, table and worktree is done under a lock in logs/locks/, and a lane that finds a
# run locked skips it (the other lane is doing it). Start the second lane in the idle scheduling
# class so that it only uses a core the first leaves free and the first lane's wall times stay
# those of a machine to itself:  chrt -i 0 bash docs/results/claims/run_experiments.sh E2 E2B E4 E5 E3B
# Run the script once more after both lanes finish: it skips every finished run and fills in
# what a lane skipped (a test or table whose run the other lane still held). Before committing
# finished runs: bash docs/results/claims/run_experiments.sh PRUNE (drops their resume-only files);
# bash docs/results/claims/run_experiments.sh STATUS lists each experiment's runs so far.
set -euo pipefail
root=$(git rev-parse --show-toplevel)
cd "$root"
py="$root/.venv/bin/python"
out=docs/results/claims
locks="$root/logs/locks"
mkdir -p "$locks"

with_lock() {  # with_lock KEY CMD...: run CMD holding KEY's lock; skip it when the other lane holds it
  local key=$1; shift
  (
    flock -n 9 || { echo "-- skipped, the other lane holds it: $key"; exit 0; }
    "$@"
  ) 9>"$locks/${key//\//_}.lock"
}

code_at() {  # the worktree of commit $1 (created once)
  local wt="$root/../wt-$1"
  ( flock 9; [ -d "$wt" ] || git worktree add -q "$wt" "$1" ) 9>"$locks/worktrees.lock"
  echo "$wt/src"
}

done_run() {  # a finished run: summary.json without "done": false (grn evolve writes one every generation)
  "$py" -c 'import sys; from pathlib import Path; from evodevo.reproduce.run_files import finished
p = Path(sys.argv[1]) / "summary.json"; sys.exit(0 if p.is_file() and finished(p) else 1)' "$1"
}

prune() {  # PRUNE: drop what only resuming needs from every finished run (before committing them)
  "$py" - "$out" <<'EOF'
import sys
from pathlib import Path

from evodevo.reproduce.run_files import finished

resume_only = ("checkpoint.npz", "rl_model_*_steps.safetensors", "candidate_*_steps.safetensors",
               "neat-checkpoint-*.json", "neat_state.json", "task*_ep*.safetensors")
for summary in sorted(Path(sys.argv[1]).rglob("summary.json")):
    folder = summary.parent / "checkpoints"
    if not folder.is_dir() or not finished(summary):
        continue
    tasks = sorted(folder.glob("task[0-9].safetensors"))  # a BIARM run keeps its last column stack
    for path in [p for pattern in resume_only for p in folder.glob(pattern)] + tasks[:-1]:
        path.unlink()
        print(f"pruned {path}")
EOF
}

status() {  # STATUS: per registered experiment, the runs whose result file exists so far
  "$py" - "$out" <<'EOF'
import sys
from pathlib import Path

from evodevo.errors import EvodevoError
from evodevo.evidence.experiment import load_experiment, read_arms
from evodevo.seeding import parse_seeds

out = Path(sys.argv[1])
for path in sorted(out.glob("*.yaml")):
    spec, root = load_experiment(path)
    n = len(parse_seeds(spec.seeds, "seeds"))
    try:
        found = {a: len(s.seeds) for a, s in read_arms(spec, root)[0].items() if not s.reference}
    except EvodevoError:  # no result file yet
        found = {a: 0 for a, t in spec.arms.items() if "{seed}" in t}
    done = sum(found.values())
    arms = ", ".join(f"{a} {k}/{n}" for a, k in found.items())
    print(f"{spec.name}: {done} of {n * len(found)} runs ({arms})")
# E1 and E5 are read by `biarm report` from E1's folder: its finished runs per variant (seeds 0-9)
variants = {"E1": ("pnn", "biarm", "single"), "E5": ("no-da", "no-5ht", "no-ne", "no-ach")}
for name, arms in variants.items():
    got = {v: sum((out / "default" / "runs" / f"{v}__s{s}" / "summary.json").is_file()
                  for s in range(10)) for v in arms}
    print(f"{name}: {sum(got.values())} of {10 * len(arms)} runs ("
          + ", ".join(f"{v} {k}/10" for v, k in got.items()) + ")")
EOF
}

decide() {  # decide g1: the experiment's tables from its runs so far (analysis: this checkout's code)
  with_lock "decide-$1" _decide "$1"
}

_decide() {
  "$py" -m evodevo compare experiment "$out/$1.yaml" > /dev/null || echo "decide $1: no table yet"
}

report() {  # report DIR...: redraw each biarm compare folder's tables (analysis: this checkout's code)
  local d; for d in "$@"; do with_lock "${d%/}" _report "$d"; done
}

_report() {
  "$py" -m evodevo biarm report "$1" > /dev/null || echo "report $1 failed"
}

compare() {  # compare SRC ARGS... --out DIR ...: biarm compare with the code of SRC (one at a time per DIR)
  local dir="" prev="" a
  for a in "$@"; do [ "$prev" = --out ] && dir=$a; prev=$a; done
  with_lock "${dir%/}" _compare "$@"
}

_compare() {
  local src=$1; shift
  PYTHONPATH="$src" nice -n 10 "$py" -m evodevo biarm compare --workers 2 --quiet "$@"
}

e1() {
  local src; src=$(code_at 139de91)
  for s in 0-1 2-3 4-5 6-7 8-9; do
    compare "$src" --variants pnn,biarm,single --seeds "$s" --out "$out/default"
  done
  report "$out/default"
}

e2() {
  local src; src=$(code_at 491f493)
  local eta='{CartPole-v1: {lr: 4.98e-4}, Acrobot-v1: {lr: 4.87e-4}, MountainCar-v0: {lr: 5.32e-4}, LunarLander-v3: {lr: 4.95e-4}}'
  for s in 0-1 2-3 4-5 6-7 8-9; do
    compare "$src" --protocol v1 --variants pnn,biarm,clamped --seeds "$s" --out "$out/v1"
    compare "$src" --protocol v1 --variants pnn --set "dqn.per_task=$eta" --seeds "$s" --out "$out/v1_eta"
  done
  decide e2
}

e2b() {  # E2b, only if E2 read biarm - clamped "different" with BIARM higher (claims.md)
  if ! "$py" - "$out/e2/comparisons.csv" <<'PY'
import csv, sys
from pathlib import Path
p = Path(sys.argv[1])
rows = list(csv.DictReader(p.open())) if p.is_file() else []
hit = [r for r in rows if r["family"] == "decision" and (r["a"], r["b"]) == ("biarm", "clamped")]
ok = bool(hit) and int(hit[0]["n"]) == 10 and hit[0]["verdict"] == "different"
sys.exit(0 if ok and float(hit[0]["mean_diff"]) > 0 else 1)
PY
  then
    echo "E2b: not run (E2 is unfinished or did not read biarm - clamped 'different' with BIARM higher)"
    return 0
  fi
  local old new arms=lr-only,gates-only chk="$out/v1_paths_identity"
  old=$(code_at 491f493); new=$(code_at aae0582)
  # the code clause: biarm seed 0 at 0.02 x the budget, at E2's commit and at the variants' one
  compare "$old" --protocol v1 --episodes-scale 0.02 --variants biarm --seeds 0 --out "$chk/491f493"
  compare "$new" --protocol v1 --episodes-scale 0.02 --variants biarm --seeds 0 --out "$chk/aae0582"
  if ! cmp -s "$chk/491f493/runs/biarm__s0/metrics.csv" "$chk/aae0582/runs/biarm__s0/metrics.csv"; then
    echo "E2b: biarm differs between 491f493 and aae0582: biarm and clamped re-run in v1_paths" \
      "(point e2b.yaml's biarm and clamped arms at v1_paths/runs/)"
    arms=lr-only,gates-only,biarm,clamped
  fi
  for s in 0-1 2-3 4-5 6-7 8-9; do
    compare "$new" --protocol v1 --variants "$arms" --seeds "$s" --out "$out/v1_paths"
  done
  decide e2b
}

e3a() {  # the lateral scale of E3 (selection seeds 100-102; never reported)
  local src; src=$(code_at 9bb2eec)
  compare "$src" --sequence cartpole-dynamics --variants single --seeds 100-102 --out "$out/transfer_scale/single"
  for scale in 1e-4 1e-2 1; do
    compare "$src" --sequence cartpole-dynamics --variants pnn --set "network.lateral_scale=$scale" \
      --seeds 100-102 --out "$out/transfer_scale/pnn_$scale"
  done
}

grn_arm() {  # grn_arm SRC ARM SEED ARGS...: evolve (resuming) and test on the locked range
  with_lock "$out/regulation/${2}_s$3" _grn_arm "$@"
}

_grn_arm() {
  local src=$1 arm=$2 seed=$3; shift 3
  local run="$out/regulation/${arm}_s$seed"
  if ! done_run "$run"; then
    local resume=(); [ -f "$run/config.json" ] && resume=(--resume)
    PYTHONPATH="$src" nice -n 10 "$py" -m evodevo grn evolve --preset vision --seed "$seed" \
      --workers 2 --quiet "${resume[@]}" "$@" --out "$run"
  fi
  locked_test "$src" "$run"
}

g1() {
  local src; src=$(code_at 3b679d4)
  for seed in 0 1 2 3 4 5 6 7; do
    grn_arm "$src" grn "$seed" --keep validated
    grn_arm "$src" noreg "$seed" --keep validated --set genome.regulation=false
    grn_arm "$src" linear "$seed" --keep validated --controller linear
    grn_arm "$src" mlp "$seed" --keep validated --controller mlp
  done
  decide g1
}

g3() {  # G1's GRN, its blind twin, PPO and NEAT on the same features and budget
  local src; src=$(code_at 3b679d4)
  local refs="$out/regulation/baselines_locked.json"  # the untrained references, once
  if [ ! -f "$refs" ]; then
    PYTHONPATH="$src" nice -n 10 "$py" -m evodevo grn baselines --config "${src%/src}/configs/grn_vision.yaml" \
      --test-episodes 200 --objects test --test-seed 1000000 --workers 2 --quiet --out "$refs"
  fi
  for seed in 0 1 2 3 4 5 6 7; do  # seeds 6-7: the amendment of 2026-12-07 (claims.md, G3)
    grn_arm "$src" grn "$seed" --keep validated
    grn_arm "$src" blind "$seed" --keep validated --blind
    for m in ppo neat; do
      sb3_arm "$src" "$out/regulation/${m}_s$seed" --method "$m" --seed "$seed" \
        --config "${src%/src}/configs/baselines_kuka_vision.yaml" --set keep.rule=validated \
        --budget-from "$out/regulation/grn_s$seed" --workers 2 --quiet
    done
  done
  decide g3
  decide g3_as_registered  # the registered 6-run design's reading, beside the amended one
}

g4() {  # G1's GRN runs tested with noise on the visual features (SPEC §2.5), locked range
  local src; src=$(code_at 3b679d4)
  for seed in 0 1 2 3 4 5 6 7; do
    local run="$out/regulation/grn_s$seed"
    done_run "$run" || grn_arm "$src" grn "$seed" --keep validated
    if done_run "$run"; then with_lock "$run" noisy_test "$src" "$run"; fi
  done
  decide g4
}

noisy_test() {  # noisy_test SRC RUN: G4's test with noise on the visual features, once
  local src=$1 run=$2
  if [ ! -f "$run/test_locked_noisy.json" ]; then
    PYTHONPATH="$src" nice -n 10 "$py" -m evodevo grn evaluate "$run" --test-episodes 200 \
      --objects test --noise 0.03 --test-seed 1000000 --no-baselines --workers 2 --json \
      > "$run/test_locked_noisy.json.part"
    mv "$run/test_locked_noisy.json.part" "$run/test_locked_noisy.json"
  fi
}

g5() {  # the neuromodulated GRN of SPEC §5 beside G1's plain one
  local src; src=$(code_at 3b679d4)
  for seed in 0 1 2 3 4 5; do
    grn_arm "$src" grn "$seed" --keep validated
    grn_arm "$src" neuromod "$seed" --keep validated --controller neuromodulated
  done
  decide g5
}

g6() {  # CMA-ES beside G1's GA runs (the GRN arm), same preset, budget and return rule
  local src; src=$(code_at 3b679d4)
  for seed in 0 1 2 3 4 5; do
    grn_arm "$src" grn "$seed" --keep validated
    grn_arm "$src" cmaes "$seed" --keep validated --optimizer cmaes
  done
  decide g6
}

e4() {  # learned module networks beside E1's fixed ones
  local src; src=$(code_at 7dac07f)
  for s in 0-1 2-3 4-5 6-7; do
    compare "$src" --variants biarm --set modules.learning=learned --seeds "$s" --out "$out/default_learned"
  done
  report "$out/default_learned" "$out/default"
  decide e4
}

g2() {  # the memory task: evolved arms, then the SB3 arms on the same env-step budget
  local src; src=$(code_at 66abad3)
  local base=(--config "${src%/src}/configs/grn_memory.yaml" --keep validated)  # the pinned commit's configs
  for seed in 0 1 2 3 4 5 6 7; do
    mem_arm "$src" carried "$seed" "${base[@]}"
    mem_arm "$src" restarted "$seed" "${base[@]}" --set dynamics.restart=true
    mem_arm "$src" linear "$seed" "${base[@]}" --controller linear
    for m in recurrent_ppo ppo; do
      sb3_arm "$src" "$out/memory/${m}_s$seed" --method "$m" --seed "$seed" \
        --config "${src%/src}/configs/baselines_kuka_memory.yaml" --set keep.rule=validated \
        --budget-from "$out/memory/carried_s$seed" --quiet
    done
  done
  decide g2
}

sb3_arm() {  # sb3_arm SRC RUN ARGS...: train a Kuka baseline (resuming), then the locked test
  with_lock "$2" _sb3_arm "$@"
}

_sb3_arm() {
  local src=$1 run=$2; shift 2
  if ! done_run "$run"; then
    local resume=(); [ -f "$run/config.json" ] && resume=(--resume)
    PYTHONPATH="$src" nice -n 10 "$py" -m evodevo baselines kuka "$@" "${resume[@]}" --out "$run"
  fi
  locked_test "$src" "$run"
}

mem_arm() {  # mem_arm SRC ARM SEED ARGS...: evolve on the memory task, then the locked test
  with_lock "$out/memory/${2}_s$3" _mem_arm "$@"
}

_mem_arm() {
  local src=$1 arm=$2 seed=$3; shift 3
  local run="$out/memory/${arm}_s$seed"
  if ! done_run "$run"; then
    local resume=(); [ -f "$run/config.json" ] && resume=(--resume)
    PYTHONPATH="$src" nice -n 10 "$py" -m evodevo grn evolve --seed "$seed" --workers 2 --quiet \
      "${resume[@]}" "$@" --out "$run"
  fi
  locked_test "$src" "$run"
}

locked_test() {  # 200 held-out-object episodes on the locked range, once (GRN or SB3 run)
  local src=$1 run=$2 cmd=(grn evaluate)
  case "$run" in */recurrent_ppo_s*|*/ppo_s*|*/neat_s*) cmd=(baselines evaluate);; esac
  if [ ! -f "$run/test_locked.json" ]; then
    PYTHONPATH="$src" nice -n 10 "$py" -m evodevo "${cmd[@]}" "$run" --test-episodes 200 \
      --objects test --test-seed 1000000 --no-baselines --workers 2 --json > "$run/test_locked.json.part"
    mv "$run/test_locked.json.part" "$run/test_locked.json"
  fi
}

retest() {  # the saved models behind README's older rows, re-tested on the locked range (no training)
  local src; src=$(code_at 7b8b64f)
  local refs="$out/regulation/baselines_locked.json"  # G3's untrained references (same env)
  if [ ! -f "$refs" ]; then
    PYTHONPATH="$src" nice -n 10 "$py" -m evodevo grn baselines --config "${src%/src}/configs/grn_vision.yaml" \
      --test-episodes 200 --objects test --test-seed 1000000 --workers 2 --quiet --out "$refs"
  fi
  local run cmd
  for run in docs/results/thesis/grn/{plain,neuromodulated}_s{0,1,2} docs/results/thesis/grn/{blind,openloop}_s0 \
      docs/results/thesis/kuka/{ppo,neat}_x{1,5}_s{0,1} docs/results/thesis/kuka/td3_x5_s{0,1} \
      docs/results/grn_vision/{vision7_record,vision9_nm}_s{0,1,2}; do  # the last two added 2026-12-08
    cmd=(grn evaluate); case "$run" in */kuka/*) cmd=(baselines evaluate);; esac
    if [ ! -f "$run/test_locked.json" ]; then
      PYTHONPATH="$src" nice -n 10 "$py" -m evodevo "${cmd[@]}" "$run" --test-episodes 200 \
        --objects test --test-seed 1000000 --no-baselines --workers 2 --json > "$run/test_locked.json.part"
      mv "$run/test_locked.json.part" "$run/test_locked.json"
    fi
  done
}

general() {  # the GRN beyond Kuka (docs/results/grn_general.md): its runs were not kept, so trained anew
  local src; src=$(code_at 87949c1)
  local env kind seed
  for env in pendulum mountaincar; do
    for seed in 0 1 2 3 4; do
      for kind in plain neuromodulated; do
        general_arm "$src" docs/results/grn_general "$env" "$kind" "$seed"
      done
    done
  done
}

g7() {  # neuromodulated vs plain GRN beyond Kuka on fresh seeds (GENERAL's code and budget)
  local src; src=$(code_at 87949c1)
  local env kind seed
  for env in mountaincar pendulum; do
    for seed in 5 6 7 8 9 10 11 12 13 14; do
      for kind in plain neuromodulated; do
        general_arm "$src" "$out/general" "$env" "$kind" "$seed"
      done
    done
  done
  decide g7
  decide g7_pendulum
}

general_arm() {  # general_arm SRC DIR ENV KIND SEED: evolve (resuming), then 40 locked-range test episodes
  with_lock "$2/${3}_${4}_s$5" _general_arm "$@"
}

_general_arm() {
  local src=$1 dir=$2 env=$3 kind=$4 seed=$5
  local run="$dir/${env}_${kind}_s$seed" extra=()
  [ "$env" = mountaincar ] && extra=(--generations 8 --episodes 5)
  if ! done_run "$run"; then
    local resume=(); [ -f "$run/config.json" ] && resume=(--resume)
    PYTHONPATH="$src" nice -n 10 "$py" -m evodevo grn evolve --config "${src%/src}/configs/grn_$env.yaml" \
      --controller "$kind" --seed "$seed" "${extra[@]}" --keep validated --workers 2 --quiet "${resume[@]}" --out "$run"
  fi
  if [ ! -f "$run/test_locked.json" ]; then
    PYTHONPATH="$src" nice -n 10 "$py" -m evodevo grn evaluate "$run" --objects train --test-episodes 40 \
      --test-seed 1000000 --workers 2 --json > "$run/test_locked.json.part"
    mv "$run/test_locked.json.part" "$run/test_locked.json"
  fi
}

e5() {  # the module ablations beside E1's runs
  local src; src=$(code_at 4532c39)
  for s in 0-1 2-3 4-5 6-7 8-9; do
    compare "$src" --variants no-da,no-5ht,no-ne,no-ach --seeds "$s" --out "$out/default"
  done
  report "$out/default"
}

e3b() {  # E3's comparison at the scale phase A chose (both task orders, seeds 0-7 as amended)
  local src; src=$(code_at 9bb2eec)
  local scale; scale=$("$py" docs/results/claims/choose_lateral_scale.py)  # analysis: this checkout's code
  echo "E3: lateral scale $scale (phase A)"
  for order in cartpole-dynamics cartpole-dynamics-reversed; do
    for s in 0-1 2-3 4-5 6-7; do
      compare "$src" --sequence "$order" --variants pnn,biarm,single \
        --set "network.lateral_scale=$scale" --seeds "$s" --out "$out/transfer/$order"
      compare "$src" --sequence "$order" --variants biarm --set modules.learning=learned \
        --set "network.lateral_scale=$scale" --seeds "$s" --out "$out/transfer/$order-learned"
    done
  done
  report "$out"/transfer/*/
  decide e3
}

# Each experiment runs in a subshell that stops at its first failure; a failed experiment is
# reported and the queue goes on with the next one (its runs are retried on the next call).
main() {
  failed=()
  for e in "${@:-E1 E3A RETEST GENERAL G7 G3 G1 G4 E2 E2B G6 E4 G5 E5 G2 E3B}"; do
    for x in $e; do
      echo "== $x $(date -u +%FT%TZ)"
      set +e
      ( set -e; "${x,,}" )
      rc=$?
      set -e
      if [ "$rc" -ne 0 ]; then
        echo "== $x FAILED (exit $rc) $(date -u +%FT%TZ); going on with the next experiment"
        failed+=("$x")
      fi
    done
  done
  if [ "${#failed[@]}" -gt 0 ]; then
    echo "== failed: ${failed[*]}"
    exit 1
  fi
  echo "== all done $(date -u +%FT%TZ)"
}

# Sourced (tests/test_run_experiments.py), it only defines the functions.
if [ "${BASH_SOURCE[0]}" = "$0" ]; then
  main "$@"
fi
