#!/usr/bin/env bash
# One box: hevo's cluster path (a `hevo serve` master and N `hevo-worker` processes talking gRPC)
# on this machine's loopback, for trying the distributed setup without a cluster. It generates a
# client token and a worker token, starts the master and the workers, submits an experiment,
# watches it to the end, fetches the results into --out and stops every process it started, also
# on Ctrl-C, on SIGTERM and on failure.
#
#   deploy/local/one-box.sh --workers 3 deploy/local/tiny.toml --out results/
#
# Run it with --help for the options. The master's state, the tokens and the logs live in a
# scratch directory that is removed after a successful run and kept (and named) after a failure.
set -euo pipefail

usage() {
    cat <<'EOF'
usage: one-box.sh [options] EXPERIMENT

Starts a hevo master and N workers on 127.0.0.1, runs EXPERIMENT on them and fetches the results.

options:
  --workers <N>      worker processes to start (default 3)
  --threads <T>      evaluation threads per worker (default 1)
  --out <DIR>        where the results are fetched to (default results)
  --bin-dir <DIR>    where hevo and hevo-worker are (default: target/release of this
                     repository when built, else PATH)
  --work-dir <DIR>   keep the master's state, the tokens and the logs in DIR (default: a
                     temporary directory, removed after a successful run)
  --grace <S>        seconds a worker gets to hand back its batch when stopped (default 90)
  --node <N>, --runs <R>, --generations <G>, --seed <S>
                     passed to `hevo submit`
  -h, --help         this text
EOF
}

die() {
    echo "one-box: $*" >&2
    exit 2
}

log() {
    echo "one-box: $*" >&2
}

workers=3
threads=1
out=results
bin_dir=""
work_dir=""
grace=90
experiment=""
submit_args=()

while (($# > 0)); do
    case "$1" in
        -h | --help)
            usage
            exit 0
            ;;
        --workers | --threads | --out | --bin-dir | --work-dir | --grace | --node | --runs | --generations | --seed)
            (($# >= 2)) || die "$1 needs a value"
            case "$1" in
                --workers) workers=$2 ;;
                --threads) threads=$2 ;;
                --out) out=$2 ;;
                --bin-dir) bin_dir=$2 ;;
                --work-dir) work_dir=$2 ;;
                --grace) grace=$2 ;;
                *) submit_args+=("$1" "$2") ;;
            esac
            shift 2
            ;;
        -*) die "unknown option $1 (see --help)" ;;
        *)
            [[ -z $experiment ]] || die "one experiment file only (got $experiment and $1)"
            experiment=$1
            shift
            ;;
    esac
done

[[ -n $experiment ]] || {
    usage >&2
    exit 2
}
[[ -f $experiment ]] || die "no such experiment file: $experiment"
[[ $workers =~ ^[1-9][0-9]*$ ]] || die "--workers must be a positive number, got $workers"
[[ $threads =~ ^[1-9][0-9]*$ ]] || die "--threads must be a positive number, got $threads"
[[ $grace =~ ^[0-9]+$ ]] || die "--grace must be a number of seconds, got $grace"

# The binaries: the ones this repository built, when they exist, so that a fresh
# `cargo build --release` is all it takes; otherwise whatever is installed.
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
if [[ -z $bin_dir && -x $repo/target/release/hevo && -x $repo/target/release/hevo-worker ]]; then
    bin_dir=$repo/target/release
fi
if [[ -n $bin_dir ]]; then
    hevo=$bin_dir/hevo
    hevo_worker=$bin_dir/hevo-worker
else
    hevo=$(command -v hevo) || die "hevo is not on PATH; build it (cargo build --release -p hevo-cli -p hevo-worker) or pass --bin-dir"
    hevo_worker=$(command -v hevo-worker) || die "hevo-worker is not on PATH; pass --bin-dir"
fi
[[ -x $hevo ]] || die "not executable: $hevo"
[[ -x $hevo_worker ]] || die "not executable: $hevo_worker"

# Scratch space. A directory the user named is never deleted.
remove_work_dir=0
if [[ -z $work_dir ]]; then
    work_dir=$(mktemp -d "${TMPDIR:-/tmp}/hevo-one-box.XXXXXX")
    remove_work_dir=1
fi
mkdir -p "$work_dir"
work_dir=$(cd "$work_dir" && pwd)

# Every child runs in a process group of its own (job control on), so that a Ctrl-C in the
# terminal reaches only this script: the cleanup below then stops the workers first, while the
# master is still there to take back their batches, and the master last.
set -m

master_pid=""
worker_pids=()
watch_pid=""

# Sends SIGTERM to the given processes and waits for them, at most GRACE seconds, after which
# the remaining ones are killed. `wait` reaps them, so no zombie outlives the script.
stop_processes() {
    local grace_seconds=$1
    shift
    local pids=() pid
    for pid in "$@"; do
        if kill -0 "$pid" 2>/dev/null; then
            pids+=("$pid")
            kill -TERM "$pid" 2>/dev/null || true
        fi
    done
    ((${#pids[@]} > 0)) || return 0
    (
        sleep "$grace_seconds"
        kill -KILL "${pids[@]}" 2>/dev/null
    ) >/dev/null 2>&1 &
    local watchdog=$!
    for pid in "${pids[@]}"; do
        wait "$pid" 2>/dev/null || true
    done
    # The watchdog is a process group of its own (set -m): end it together with its sleep.
    # SIGKILL, since it was started while the cleanup ignores SIGTERM, and inherited that.
    kill -KILL -- "-$watchdog" 2>/dev/null || kill -KILL "$watchdog" 2>/dev/null || true
    wait "$watchdog" 2>/dev/null || true
}

cleanup() {
    local status=$?
    trap - EXIT
    # Stopping is bounded (the grace period), so a second Ctrl-C does not cut it short and leave
    # orphans behind.
    trap '' INT TERM
    if [[ -n $watch_pid ]]; then
        stop_processes 5 "$watch_pid"
    fi
    if ((${#worker_pids[@]} > 0)); then
        log "stopping ${#worker_pids[@]} workers (up to ${grace}s to hand back their batches)"
        stop_processes "$grace" "${worker_pids[@]}"
    fi
    if [[ -n $master_pid ]]; then
        log "stopping the master"
        stop_processes 30 "$master_pid"
    fi
    if ((status == 130 || status == 143)); then
        log "interrupted; state and logs kept in $work_dir"
    elif ((status != 0)); then
        local file
        for file in "$work_dir"/master.log "$work_dir"/worker-*.log; do
            [[ -s $file ]] || continue
            echo "--- last lines of $file" >&2
            tail -n 20 "$file" >&2
        done
        log "failed (exit $status); state and logs kept in $work_dir"
    elif ((remove_work_dir)); then
        rm -rf "$work_dir"
    else
        log "state and logs kept in $work_dir"
    fi
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# Two fresh random tokens, one per role: the master takes the clients' (submit, watch, fetch)
# and the workers' and refuses anyone without the one of their role. They go through files, not
# the command line, so that they do not show in `ps`.
new_token() {
    (
        umask 077
        od -An -N32 -tx1 /dev/urandom | tr -d ' \n' >"$1"
    )
}
client_token_file=$work_dir/token
worker_token_file=$work_dir/worker-token
new_token "$client_token_file"
new_token "$worker_token_file"

log "starting the master ($hevo)"
# Created here, not by the background job's redirection, so the loop below never reads a file
# that does not exist yet.
: >"$work_dir/master.out"
"$hevo" serve --listen 127.0.0.1:0 --metrics-listen 127.0.0.1:0 --state-dir "$work_dir/state" \
    --token-file "$client_token_file" --worker-token-file "$worker_token_file" \
    >"$work_dir/master.out" 2>"$work_dir/master.log" &
master_pid=$!

# Port 0 lets the kernel pick a free port, so several one-boxes (and CI jobs) can run side by
# side; the master announces the port on its first line.
address=""
for _ in $(seq 1 300); do
    address=$(awk '/^listening on / { print $3; exit }' "$work_dir/master.out")
    [[ -z $address ]] || break
    kill -0 "$master_pid" 2>/dev/null || die "the master exited before listening (see $work_dir/master.log)"
    sleep 0.1
done
[[ -n $address ]] || die "the master did not announce its address within 30 s"
master_url=http://$address
metrics=$(awk '/^metrics on / { print $3; exit }' "$work_dir/master.out")
log "master at $master_url${metrics:+, metrics at http://$metrics/metrics}"

for ((i = 1; i <= workers; i++)); do
    "$hevo_worker" --master "$master_url" --token-file "$worker_token_file" --threads "$threads" \
        --name "one-box-$i" >"$work_dir/worker-$i.log" 2>&1 &
    worker_pids+=("$!")
done
log "started $workers workers with $threads threads each"

job=$("$hevo" submit --master "$master_url" --token-file "$client_token_file" "$experiment" ${submit_args[@]+"${submit_args[@]}"})
log "submitted $experiment as job $job"

# In the background and waited for, so that Ctrl-C interrupts the wait at once instead of
# waiting for the job to end.
"$hevo" watch --master "$master_url" --token-file "$client_token_file" "$job" &
watch_pid=$!
watch_status=0
wait "$watch_pid" || watch_status=$?
watch_pid=""
((watch_status == 0)) || die "job $job did not succeed (hevo watch exited $watch_status)"

mkdir -p "$out"
"$hevo" fetch --master "$master_url" --token-file "$client_token_file" "$job" --out "$out"
log "results of job $job are in $out"
