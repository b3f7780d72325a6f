#!/usr/bin/env bash
# Figure 2 on the corrected game, timed end to end (issue 51's measure): PPO, SAC, TD3 x 5
# seeds, 64x64, the whole protocol, the scripted baselines, then the report with the
# planner beside them; two runs at a time, one thread each, on the build of BIN (default
# target/release) and the configs of CONFIGS (default configs/, whose `backend = "auto"`
# puts 64x64 networks on the host MLP path), into OUT (default results/figure2-v5), the
# planner's figures from PLANNER (default results/planner/reference-v5; played first if
# missing, inside the segment's time).
#
#   nohup bash tools/figure2_timed.sh > runs/logs/figure2-timed.out 2>&1 &
#
# Run again after an interruption, it resumes from the runs' epoch checkpoints. Every
# segment's start and end go to OUT/timing.log (committed with the results): the sweep's
# wall time is the sum of its `segment_s` (a segment cut by the machine going away has no
# end line; its end is the last file the sweep wrote).
set -uo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-target/release}
configs=${CONFIGS:-configs}
out=${OUT:-results/figure2-v5}
planner=${PLANNER:-results/planner/reference-v5}
mkdir -p "$out" runs/logs
start=$(date +%s)
echo "start $start $(date -u +%FT%TZ) rev $(cat "$bin/REV" 2>/dev/null || git rev-parse HEAD) nproc $(nproc)" >> "$out/timing.log"
"$bin/sweep" --algos ppo,sac,td3 --seeds 0..5 --hidden 64,64 --jobs 2 --configs "$configs" \
    --out "$out" >> "runs/logs/$(basename "$out").log" 2>&1
rc=$?
if [ "$rc" -eq 0 ] && [ ! -f "$planner/metrics.json" ]; then
    "$bin/evaluate" --policy planner --seed 0 --episodes 1000 --out "$planner" \
        >> "runs/logs/$(basename "$out").log" 2>&1
    rc=$?
fi
if [ "$rc" -eq 0 ]; then
    "$bin/report" "$out" "$planner" --out "$out/report" \
        >> "runs/logs/$(basename "$out").log" 2>&1
    rc=$?
fi
end=$(date +%s)
echo "end $end $(date -u +%FT%TZ) rc $rc segment_s $((end - start))" >> "$out/timing.log"
