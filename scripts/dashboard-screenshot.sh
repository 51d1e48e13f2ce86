#!/usr/bin/env bash
# Takes docs/dashboard.png, the README's picture of the dashboard: `hevo dashboard` over the
# checked-in run directory experiments/runs-wide-turn-starts, one job page photographed by
# headless chromium (from scripts/install-test-tools.sh's browser step) once its script has
# run.
#
#   scripts/dashboard-screenshot.sh [OUT.png]
#
# HEVO_BIN names the hevo binary (default: cargo build's target/debug/hevo, built first).
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-$repo/docs/dashboard.png}
tools=${HEVO_TEST_TOOLS_DIR:-$repo/.tools}
chromium=$tools/bin/chromium
[[ -x $chromium ]] || chromium=$(command -v chromium) ||
    { echo "dashboard-screenshot: no chromium (bash scripts/install-test-tools.sh browser)" >&2; exit 1; }

if [[ -z ${HEVO_BIN:-} ]]; then
    cargo build --quiet -p hevo-cli --manifest-path "$repo/Cargo.toml"
    HEVO_BIN=${CARGO_TARGET_DIR:-$repo/target}/debug/hevo
fi

scratch=$(mktemp -d)
dashboard_pid=
cleanup() {
    [[ -n $dashboard_pid ]] && kill "$dashboard_pid" 2>/dev/null
    rm -rf "$scratch"
}
trap cleanup EXIT

cd "$repo"
"$HEVO_BIN" dashboard experiments/runs-wide-turn-starts --listen 127.0.0.1:0 >"$scratch/out" &
dashboard_pid=$!
for _ in $(seq 100); do
    grep -q '^dashboard on ' "$scratch/out" && break
    sleep 0.1
done
url=$(sed -n 's/^dashboard on //p' "$scratch/out")
[[ -n $url ]] || { echo "dashboard-screenshot: hevo dashboard printed no URL" >&2; exit 1; }

"$chromium" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --user-data-dir="$scratch/profile" --hide-scrollbars --window-size=1280,2300 \
    --timeout=4000 --screenshot="$out" "$url/jobs/runs-wide-turn-starts" \
    >/dev/null 2>"$scratch/chromium.log" ||
    { cat "$scratch/chromium.log" >&2; exit 1; }
echo "dashboard-screenshot: $out"
