#!/usr/bin/env bash
# A single-node SLURM cluster on this machine's loopback, for trying deploy/slurm/hevo.sbatch
# with the real sbatch, srun, squeue and scancel (tests/tests/live_clusters/slurm_live_*.rs use
# it): munged, slurmctld and one slurmd with a partition `debug`, every file (configuration,
# munge key, sockets, state, logs) in one directory, no systemd and no change to /etc. Needs
# root (slurmd runs jobs as their users) and Debian's slurm-wlm and munge packages (or any
# SLURM 22.05+):
#
#   deploy/slurm/local-cluster.sh up DIR [--cpus N]   # start; prints the SLURM_CONF to export
#   export SLURM_CONF=DIR/slurm.conf
#   sbatch --nodes=1 --ntasks-per-node=2 --cpus-per-task=1 deploy/slurm/hevo.sbatch deploy/local/tiny.toml
#   deploy/slurm/local-cluster.sh down DIR            # stop every daemon it started
#
# The daemons talk over ports the script picks free on 127.0.0.1. Process tracking is SLURM's
# linuxproc plugin (no cgroups), and there is no accounting database: squeue and
# `scontrol show job` report jobs (finished ones for five minutes), sacct does not.
set -euo pipefail

usage() {
    cat <<'EOF'
usage: local-cluster.sh up DIR [--cpus N]
       local-cluster.sh down DIR

up    writes DIR/slurm.conf and a munge key, starts munged, slurmctld and one slurmd
      (N CPUs, default 2) in the partition `debug`, waits until the node is idle
down  stops the daemons started in DIR (scontrol shutdown, then munged)
EOF
}

die() {
    echo "local-cluster.sh: $*" >&2
    exit 2
}

log() {
    echo "local-cluster.sh: $*" >&2
}

# A TCP port on 127.0.0.1 that nothing answers on (checked, not reserved), below Linux's
# range of ephemeral ports (32768 and up), where the kernel would not hand it to a client.
free_port() {
    local port
    for _ in $(seq 1 200); do
        port=$((20000 + RANDOM % 12000))
        if ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then
            echo "$port"
            return 0
        fi
    done
    die "found no free port"
}

# Waits up to $2 seconds for process $1 to exit.
wait_gone() {
    local pid=$1 seconds=$2
    [[ -n $pid ]] || return 0
    for _ in $(seq 1 $((seconds * 10))); do
        kill -0 "$pid" 2>/dev/null || return 0
        sleep 0.1
    done
    return 1
}

# The process id in pid file $1, if any.
pid_in() {
    [[ ! -s $1 ]] || cat "$1"
}

up() {
    local dir=$1 cpus=$2
    ((EUID == 0)) || die "needs root: slurmd starts jobs as their users"
    local tool
    for tool in munged munge slurmctld slurmd sinfo scontrol; do
        command -v "$tool" >/dev/null ||
            die "no $tool: apt-get install slurm-wlm munge (Debian), or bash scripts/install-test-tools.sh slurm"
    done
    mkdir -p "$dir"
    dir=$(cd "$dir" && pwd)
    [[ ! -e $dir/slurm.conf ]] || die "$dir already holds a cluster (down it first, or use another directory)"
    local node
    node=$(hostname -s)
    # The batch script tells the workers the master's address by node name.
    getent hosts "$node" >/dev/null || die "this machine's name $node does not resolve (add it to /etc/hosts)"

    # A failed start stops what did start.
    trap 'stop_daemons "$dir"' EXIT
    # munged refuses a socket directory others may write to, or one not everyone may enter.
    mkdir -p "$dir/munge" "$dir/socket" "$dir/state" "$dir/spool" "$dir/log"
    chmod 700 "$dir/munge"
    chmod 755 "$dir" "$dir/socket"
    (
        umask 077
        dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
    )
    local socket=$dir/socket/munge.socket
    munged --socket="$socket" --key-file="$dir/munge/munge.key" \
        --log-file="$dir/log/munged.log" --pid-file="$dir/munge/munged.pid" \
        --seed-file="$dir/munge/munged.seed" ||
        die "munged did not start (see $dir/log/munged.log)"
    munge --socket="$socket" --no-input </dev/null | unmunge --socket="$socket" >/dev/null ||
        die "munge cannot encode and decode a credential"

    local controller_port node_port
    controller_port=$(free_port)
    node_port=$(free_port)
    while ((node_port == controller_port)); do node_port=$(free_port); done
    cat >"$dir/slurm.conf" <<EOF
# Written by deploy/slurm/local-cluster.sh: a one-node cluster on loopback, files in $dir.
ClusterName=hevo-local
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$controller_port
SlurmdPort=$node_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
SlurmdParameters=config_overrides
# Time between SIGTERM and SIGKILL when a job is cancelled or preempted.
KillWait=30
MinJobAge=300
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=debug Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
    export SLURM_CONF=$dir/slurm.conf
    slurmctld -c || die "slurmctld did not start (see $dir/log/slurmctld.log)"
    slurmd -N "$node" || die "slurmd did not start (see $dir/log/slurmd.log)"
    local state=""
    for _ in $(seq 1 300); do
        state=$(sinfo --noheader --nodes="$node" --format=%T 2>/dev/null || true)
        [[ $state != idle ]] || break
        sleep 0.1
    done
    [[ $state == idle ]] ||
        die "the node $node is ${state:-unknown}, not idle, after 30 s (see $dir/log/slurmctld.log and slurmd.log)"
    trap - EXIT
    log "node $node idle with $cpus CPUs in partition debug; daemons' logs in $dir/log"
    echo "export SLURM_CONF=$dir/slurm.conf"
}

# Stops whichever of the daemons started in $1 are running.
stop_daemons() {
    local dir=$1
    export SLURM_CONF=$dir/slurm.conf
    local slurmd_pid slurmctld_pid munged_pid pid
    # Read first: the daemons remove their pid files as they exit.
    slurmd_pid=$(pid_in "$dir/slurmd.pid")
    slurmctld_pid=$(pid_in "$dir/slurmctld.pid")
    munged_pid=$(pid_in "$dir/munge/munged.pid")
    # Shuts down slurmctld and every slurmd it knows.
    [[ ! -f $SLURM_CONF ]] || scontrol shutdown >/dev/null 2>&1 || true
    for pid in "$slurmd_pid" "$slurmctld_pid"; do
        if ! wait_gone "$pid" 30; then
            log "process $pid did not stop: SIGKILL"
            kill -KILL "$pid" 2>/dev/null || true
        fi
    done
    if [[ -n $munged_pid ]]; then
        kill -TERM "$munged_pid" 2>/dev/null || true
        wait_gone "$munged_pid" 10 || kill -KILL "$munged_pid" 2>/dev/null || true
    fi
}

down() {
    local dir=$1
    [[ -f $dir/slurm.conf ]] || die "no cluster in $dir"
    stop_daemons "$dir"
    log "stopped the cluster in $dir"
}

command=${1:-}
case "$command" in
    -h | --help)
        usage
        exit 0
        ;;
    up | down) ;;
    *)
        usage >&2
        exit 2
        ;;
esac
(($# >= 2)) || die "$command needs a directory"
dir=$2
shift 2
cpus=2
while (($# > 0)); do
    case "$1" in
        --cpus)
            (($# >= 2)) || die "--cpus needs a value"
            cpus=$2
            shift 2
            ;;
        *) die "unknown option $1" ;;
    esac
done
[[ $cpus =~ ^[1-9][0-9]*$ ]] || die "--cpus takes a positive number, not $cpus"
"$command" "$dir" "$cpus"
