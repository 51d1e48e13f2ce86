#!/usr/bin/env bash
# Draws the pictures README.md and experiments/README.md show into docs/img/, with the tour's
# own commands. Run from anywhere after `cargo build --release` (or set HEVO to another `hevo`
# binary); the files are generated, so a change to the replay or plot code shows up here as a
# diff to review.
set -euo pipefail
cd "$(dirname "$0")/.."
HEVO=${HEVO:-target/release/hevo}
if [[ ! -x "$HEVO" ]]; then
    echo "error: $HEVO is not an executable; run cargo build --release first, or set HEVO" >&2
    exit 1
fi
"$HEVO" replay controllers/rescue.json --task rescue --light-config 3 --seed 1 \
    --out docs/img/rescue_replay.svg
"$HEVO" replay controllers/solve_maze.json --task solve_maze --light-config 2 --seed 4 \
    --rays 60,150 --out docs/img/solve_maze_replay.svg
"$HEVO" plot experiments/runs --node return_room --out docs/img/return_room_fitness.svg
"$HEVO" replay controllers/aggregation.json --task scenarios/swarm/aggregation.toml --seed 3 \
    --out docs/img/swarm_aggregation.svg
"$HEVO" replay controllers/mission.json --task scenarios/swarm/mission.toml --seed 3 \
    --out docs/img/swarm_mission.svg
echo "wrote docs/img/rescue_replay.svg, docs/img/solve_maze_replay.svg, docs/img/return_room_fitness.svg, docs/img/swarm_aggregation.svg, docs/img/swarm_mission.svg"
