#!/usr/bin/env bash
# Issue 48's re-runs on the corrected `reference` game (the fifth: rods as MuJoCo moves
# them, ball-man contacts as its SDF search finds them and its soft law makes them;
# docs/reference-game.md), in order, two trainings at a time: the
# planner's ceiling, Figure 2 (PPO, SAC, TD3 x 5 seeds, 64x64, the whole protocol, with
# the scripted baselines and the report, timed: tools/figure2_timed.sh), the recipe's
# demonstrations, then the recipe (5 seeds). Run again after an interruption, it skips
# what is finished and resumes the rest (the sweep and `train --resume` go on from their
# checkpoints).
#
#   nohup bash tools/corrected_game_reruns.sh > runs/logs/queue.out 2>&1 &
#
# Progress: runs/logs/queue.log (a line per finished step), runs/logs/*.log, and
# `$BIN/sweep --status --out results/figure2-v5`.
#
# BIN=DIR takes the binaries from DIR (default target/release) and CONFIGS=DIR the configs
# (default configs/): the runs begun with one build must be resumed with the same code, or
# their later epochs compute on other rounding; keep a copy of both
# (`runs/bin-<rev>`, `git archive <rev> configs`) while the code moves on.
set -uo pipefail
cd "$(dirname "$0")/.."
mkdir -p runs/logs runs/demos
bin=${BIN:-target/release}
configs=${CONFIGS:-configs}
log=runs/logs/queue.log
echo "$(date -u +%FT%TZ) queue start rev $(cat "$bin/REV" 2>/dev/null || git rev-parse HEAD)" >> "$log"

# 0. The planner's ceiling on the test starts (seed 0, the default budget).
if [ ! -f results/planner/reference-v5/metrics.json ]; then
    "$bin/evaluate" --policy planner --seed 0 --episodes 1000 --out results/planner/reference-v5 \
        >> runs/logs/planner-v5.log 2>&1
fi
echo "$(date -u +%FT%TZ) planner done rc=$?" >> "$log"

# 1. Figure 2 with its baselines and report, timed.
BIN="$bin" CONFIGS="$configs" OUT=results/figure2-v5 PLANNER=results/planner/reference-v5 \
    bash tools/figure2_timed.sh
echo "$(date -u +%FT%TZ) figure2-v5 done rc=$?" >> "$log"

# 2. The recipe's demonstrations (the path configs/sac-recipe.toml reads).
printf 'population = 64\nelites = 8\niterations = 15\nshared_starts = 48\nrefine_std = 0.2\n' > runs/demos/refined.toml
if [ ! -f runs/demos/refined1800-seed1000/trajectories.bin ]; then
    "$bin/evaluate" --policy planner --planner runs/demos/refined.toml --seed 1000 --episodes 1800 \
        --out runs/demos/refined1800-seed1000 >> runs/logs/demos.log 2>&1
fi
echo "$(date -u +%FT%TZ) demos done rc=$?" >> "$log"

# 3. The recipe, 5 seeds, two at a time.
recipe() {
    local s=$1 out=results/recipe-v5/sac-recipe-seed$1
    if [ -f "$out/test/metrics.json" ]; then return; fi
    if [ -d "$out/checkpoint" ]; then
        "$bin/train" --resume "$out" --threads 1 >> "runs/logs/recipe-v5-$s.log" 2>&1
    else
        "$bin/train" --config "$configs/sac-recipe.toml" --seed "$s" --threads 1 --out "$out" \
            >> "runs/logs/recipe-v5-$s.log" 2>&1
    fi
    echo "$(date -u +%FT%TZ) recipe seed $s done rc=$?" >> "$log"
}
(recipe 0; recipe 2; recipe 4) &
(recipe 1; recipe 3) &
wait
echo "$(date -u +%FT%TZ) queue end" >> "$log"
