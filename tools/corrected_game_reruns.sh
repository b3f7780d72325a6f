#!/usr/bin/env bash
# Issue 48's re-runs on the corrected `reference` game, in order, two trainings at a time:
# the planner's ceiling, Figure 2 (PPO, SAC, TD3 x 5 seeds, 64x64, the whole protocol,
# with the scripted baselines), the recipe's demonstrations, then the recipe (5 seeds).
# Run again after an interruption, it skips what is finished and resumes the rest (the
# sweep and `train --resume` go on from their checkpoints).
#
#   cargo build --release --bins && nohup bash tools/corrected_game_reruns.sh &
#
# Progress: runs/logs/queue.log (a line per finished step), runs/logs/*.log, and
# `target/release/sweep --status --out results/figure2-v3`.
#
# BIN=DIR takes the binaries from DIR: the runs begun with one build must be resumed with
# the same code, or their later epochs compute on other rounding (Figure 2 v3 began on
# 0e584fd's; SAC's update was rewritten after it, the same math, not the same bits), and
# the configs of CONFIGS_REV (default 0e584fd), extracted into runs/configs-<rev>.
set -uo pipefail
cd "$(dirname "$0")/.."
mkdir -p runs/logs
bin=${BIN:-target/release}
# The sweep plans from `configs/<algo>.toml`; binaries of another build read that build's
# files (0e584fd's, for Figure 2 v3's: they predate `backend = "auto"`).
configs=configs
if [ -n "${BIN:-}" ]; then
    configs=runs/configs-${CONFIGS_REV:-0e584fd}
    if [ ! -d "$configs" ]; then
        mkdir -p "$configs" && git archive "${CONFIGS_REV:-0e584fd}" configs | tar -x -C "$configs" --strip-components=1
    fi
fi
log=runs/logs/queue.log
echo "$(date -u +%FT%TZ) queue start" >> "$log"

# 0. The planner's ceiling on the test starts (seed 0, the default budget).
if [ ! -f results/planner/reference-v3/metrics.json ]; then
    $bin/evaluate --policy planner --seed 0 --episodes 1000 --out results/planner/reference-v3 \
        >> runs/logs/planner-v3.log 2>&1
fi
echo "$(date -u +%FT%TZ) planner done rc=$?" >> "$log"

# 1. Figure 2: PPO, SAC, TD3 x 5 seeds, 64x64, the whole protocol, with the baselines.
$bin/sweep --algos ppo,sac,td3 --seeds 0..5 --hidden 64,64 --jobs 2 --configs "$configs" \
    --out results/figure2-v3 >> runs/logs/figure2-v3.log 2>&1
echo "$(date -u +%FT%TZ) figure2-v3 done rc=$?" >> "$log"
# Its report again with the planner beside the learners and the baselines.
$bin/report results/figure2-v3 results/planner/reference-v3 --out results/figure2-v3/report \
    >> runs/logs/figure2-v3.log 2>&1

# 2. The recipe's demonstrations on the corrected game (configs/sac-recipe.toml).
mkdir -p runs/demos
printf 'population = 64\nelites = 8\niterations = 15\nshared_starts = 48\nrefine_std = 0.2\n' > runs/demos/refined.toml
if [ ! -f runs/demos/refined1800-seed1000/trajectories.bin ]; then
    $bin/evaluate --policy planner --planner runs/demos/refined.toml --seed 1000 --episodes 1800 \
        --out runs/demos/refined1800-seed1000 >> runs/logs/demos.log 2>&1
fi
echo "$(date -u +%FT%TZ) demos done rc=$?" >> "$log"

# 3. The recipe, 5 seeds, two at a time.
recipe() {
    local s=$1 out=results/recipe-v3/sac-recipe-seed$1
    if [ -f "$out/test/metrics.json" ]; then return; fi
    if [ -d "$out/checkpoint" ]; then
        $bin/train --resume "$out" --threads 1 >> runs/logs/recipe-seed$s.log 2>&1
    else
        $bin/train --config "$configs/sac-recipe.toml" --seed "$s" --threads 1 --out "$out" \
            >> runs/logs/recipe-seed$s.log 2>&1
    fi
    echo "$(date -u +%FT%TZ) recipe seed $s done rc=$?" >> "$log"
}
(recipe 0; recipe 2; recipe 4) &
(recipe 1; recipe 3) &
wait
echo "$(date -u +%FT%TZ) queue end" >> "$log"
