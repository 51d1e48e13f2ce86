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
callgrind_annotate --auto=no --threshold=100 "$out" 2>/dev/null | python3 -c '
import json, os, re, sys
cycles = json.load(open(sys.argv[1]))["cycles"]
task, evaluator = sys.argv[2], sys.argv[3]
# (part, file pattern, function pattern), matched against the file a count comes from and
# the function it is inlined into; the first match wins. Keep them in step with the code:
# an unmatched count lands in the last part, which HEVO_PROFILE_REST=1 lists.
rules = [
    ("networks (CTRNN, arbitration)", r".", r"step_network|LaneController|Controller::step|arbitrate"),
    ("IR geometry (cones, sensor poses)", r"scene\.rs$", r"read_ir|cone_"),
    ("IR reading (curves, inverse lookup, noise draws)", r".", r"read_ir|IrRun|IrModel|array::try_from_fn"),
    ("light reading (curves, noise draws)", r".", r"LightModel|LightRun|light::"),
    ("kinematics (sines, wheels, wheel noise)", r".", r"sin_cos|plan_move|move_robot|Robot::"),
    ("collision (disc test)", r".", r"disc_hits"),
    ("judging (conditions, phases, progress, endings)", r".", r"finish_cycle|holds|Atom|Quantity|observe|Judge|phase|Ending"),
    ("sensing dispatch (the frame, each sensor block called)", r".", r"sense_at|NearRobot"),
    ("world building per sample", r".", r"::new|build|Scene|room|Arena|Bvh|malloc|free|mem|start|place|rapier|parry"),
    ("the lockstep loop and the rest", r".", r"."),
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
            if part.startswith("the lockstep loop") and os.environ.get("HEVO_PROFILE_REST"):
                print(f"  rest: {count / cycles:6.1f}  {path}:{function}", file=sys.stderr)
            break
total = sum(parts.values())
print(f"{task}, {evaluator}: {cycles} cycles, {total / cycles:.0f} instructions per cycle")
for part, count in sorted(parts.items(), key=lambda kv: -kv[1]):
    print(f"  {count / cycles:6.0f}  {part}")
' "$out.json" "$task" "$evaluator"
