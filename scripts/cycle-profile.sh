#!/usr/bin/env bash
# Where a control cycle's instructions go: runs `hevo bench` under callgrind (instruction
# counts, which do not depend on the machine's load) and sums the counts by part of the cycle,
# per control cycle. Inlined code counts where it comes from (its source file) and, for library
# code (iterators, float methods), where it is inlined. Run from the repository root after
# `cargo build --release`:
#
#   scripts/cycle-profile.sh TASK [EVALUATOR] [SECONDS]
#
# EVALUATOR is scalar or lockstep (default lockstep); HEVO=path/to/hevo picks another binary.
set -euo pipefail
cd "$(dirname "$0")/.."
task=$1
evaluator=${2:-lockstep}
seconds=${3:-6}
hevo=${HEVO:-target/release/hevo}
out=$(mktemp)
trap 'rm -f "$out" "$out.json"' EXIT
valgrind --tool=callgrind --callgrind-out-file="$out" "$hevo" bench --task "$task" --threads 1 \
    --seconds "$seconds" --json --evaluator "$evaluator" 2>/dev/null | tail -n 1 >"$out.json"
callgrind_annotate --threshold=100 "$out" 2>/dev/null | python3 -c '
import json, re, sys
cycles = json.load(open(sys.argv[1]))["cycles"]
task, evaluator = sys.argv[2], sys.argv[3]
# (part, file pattern, function pattern): the first match wins.
rules = [
    ("IR geometry (cones, sensor poses)", r"blocks/sensors\.rs$|scene\.rs$", r"IrRun|sense|cone_"),
    ("sensing and loop bookkeeping", r"blocks/sensors\.rs$", r"."),
    ("judging (phases, stages, endings)", r"/scenario/", r"."),
    ("collision (disc test)", r"scene\.rs$", r"disc_hits|move_robot"),
    ("world building per sample", r"scene\.rs$|/env/|rapier|parry|glam|smallvec|malloc|memmove|memcpy|memset|_int_free|free", r"new|build|Scene|room|Arena|Bvh|insert|set_aabb|Leaves|malloc|free|mem|traverse|."),
    ("IR and light reading (curves, noise draws)", r"sensors/|rand_distr|rand_core|rand_xoshiro", r"."),
    ("networks (CTRNN, arbitration)", r"ctrnn\.rs|lanes\.rs|lockstep\.rs|controller\.rs", r"step|arbitrate|Controller|Lane"),
    ("networks (CTRNN, arbitration)", r".", r"LaneController::step|Controller::step|arbitrate"),
    ("kinematics (libm sin and cos, wheels)", r"robot\.rs|sincosf|sinf|cosf|floor", r"."),
    ("IR geometry (cones, sensor poses)", r".", r"cone_distances|cone_lane"),
    ("judging (phases, stages, endings)", r".", r"Judge|truth|holds|phase"),
    ("sensing and loop bookkeeping", r".", r"."),
]
parts = {}
for line in sys.stdin:
    m = re.match(r"^\s*([\d,]+) \([^)]*\)\s+(\S+?):(\S.*?)(?: \[.*\])?$", line)
    if not m or m.group(2) == "PROGRAM":
        continue
    count, path, function = int(m.group(1).replace(",", "")), m.group(2), m.group(3)
    for part, file_pattern, function_pattern in rules:
        if re.search(file_pattern, path) and re.search(function_pattern, function):
            parts[part] = parts.get(part, 0) + count
            break
total = sum(parts.values())
print(f"{task}, {evaluator}: {cycles} cycles, {total / cycles:.0f} instructions per cycle")
for part, count in sorted(parts.items(), key=lambda kv: -kv[1]):
    print(f"  {count / cycles:6.0f}  {part}")
' "$out.json" "$task" "$evaluator"
