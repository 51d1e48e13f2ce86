#!/usr/bin/env bash
# Paired throughput of two `hevo` binaries, for a change's old against new: per task and thread
# count, `OLD bench` and `NEW bench` run one after the other, the order swapped every round, and
# the summary gives each side's median and the median of the per-round ratios, which a load
# change on a shared machine hits far less than either figure alone. Run from the repository
# root:
#
#   scripts/paired-bench.sh OLD_HEVO NEW_HEVO [ROUNDS] [SECONDS] [NEW_FLAGS] [OLD_FLAGS]
#
# NEW_FLAGS go to the new binary and OLD_FLAGS to the old one (an older binary may lack a
# flag), e.g. "--evaluator lockstep" for both when two lockstep builds are compared.
# TASKS="solve_maze rescue" and THREADS="1" narrow the run to those tasks and thread counts.
set -euo pipefail
cd "$(dirname "$0")/.."
old=$1
new=$2
rounds=${3:-5}
seconds=${4:-3}
new_flags=${5:-}
old_flags=${6:-}
tmp=$(mktemp)
trap 'rm -f "$tmp"' EXIT

for ((round = 0; round < rounds; round++)); do
    for task in ${TASKS:-solve_maze rescue exit_room follow_wall return_room scenarios/examples/t_maze.toml \
        scenarios/examples/triple_t_maze.toml scenarios/examples/room_to_yard.toml}; do
        for n in ${THREADS:-1 2}; do
            order=(old new)
            ((round % 2 == 1)) && order=(new old)
            for who in "${order[@]}"; do
                if [[ $who == old ]]; then
                    # shellcheck disable=SC2086 # the flags are words
                    line=$("$old" bench --task "$task" --threads "$n" --seconds "$seconds" --json $old_flags | tail -n 1)
                else
                    # shellcheck disable=SC2086 # the flags are words
                    line=$("$new" bench --task "$task" --threads "$n" --seconds "$seconds" --json $new_flags | tail -n 1)
                fi
                echo "{\"who\":\"$who\",\"round\":$round,${line#\{}" >>"$tmp"
            done
        done
    done
done

python3 - "$tmp" <<'PY'
import collections, json, statistics, sys
rows = {}
for line in open(sys.argv[1]):
    r = json.loads(line)
    rows[(r["task"], r["threads"], r["who"], r["round"])] = r["cycles_per_second"]
tasks = list(dict.fromkeys(key[0] for key in rows))
rounds = sorted({key[3] for key in rows})
print("| task | threads | old, median cycles/s | new, median | new / old, median of paired ratios | range |")
print("|---|---|---|---|---|---|")
for task in tasks:
    for n in sorted({key[1] for key in rows if key[0] == task}):
        pairs = [(rows[(task, n, "old", r)], rows[(task, n, "new", r)]) for r in rounds]
        ratios = [new / old for old, new in pairs]
        print(f"| {task} | {n} | {statistics.median(p[0] for p in pairs)/1e6:.2f} M "
              f"| {statistics.median(p[1] for p in pairs)/1e6:.2f} M | {statistics.median(ratios):.2f}x "
              f"| {min(ratios):.2f}..{max(ratios):.2f} |")
PY
