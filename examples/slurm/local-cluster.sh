#!/bin/bash
# A one-node Slurm cluster of this machine, for trying the job scripts and for the tests
# (docs/scale-out.md). Everything it writes (configuration, state, spool, logs, munge socket)
# is under DIR; it listens on the loopback only. Run as root (slurmd runs jobs as their user).
#
#   local-cluster.sh start DIR    # then: export SLURM_CONF=DIR/slurm.conf
#   local-cluster.sh logs DIR
#   local-cluster.sh stop DIR
#
# Needs Debian's slurm-wlm and munge (`cargo xtask test` installs them) and the munge key the
# munge package makes, /etc/munge/munge.key.
set -euo pipefail
action=${1:?usage: local-cluster.sh start|stop|logs DIR}
dir=${2:?usage: local-cluster.sh start|stop|logs DIR}

# A port in 20000..59999 that nothing listens on.
free_port() {
    local port
    while true; do
        port=$((20000 + RANDOM % 40000))
        if ! (echo > "/dev/tcp/127.0.0.1/$port") 2>/dev/null; then
            echo "$port"
            return
        fi
    done
}

case $action in
start)
    mkdir -p "$dir/state" "$dir/spool"
    chmod 700 "$dir"
    dir=$(cd "$dir" && pwd)
    host=$(hostname -s)
    munged --force --socket="$dir/munge.socket" --key-file=/etc/munge/munge.key \
        --log-file="$dir/munged.log" --pid-file="$dir/munged.pid" --seed-file="$dir/munged.seed"
    cat > "$dir/slurm.conf" <<CONF
ClusterName=lrtlocal
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge.socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
SchedulerType=sched/builtin
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
    export SLURM_CONF=$dir/slurm.conf
    slurmctld
    slurmd
    # Up once the node is idle.
    for _ in $(seq 300); do
        if [[ $(sinfo -h -o %t 2>/dev/null) == idle ]]; then
            exit 0
        fi
        sleep 0.2
    done
    echo "local-cluster.sh: the node did not become idle within 60 s" >&2
    exit 1
    ;;
stop)
    for daemon in slurmd slurmctld munged; do
        if [[ -f $dir/$daemon.pid ]]; then
            kill "$(cat "$dir/$daemon.pid")" 2>/dev/null || true
        fi
    done
    # Wait for them to exit, so that DIR can be removed.
    for _ in $(seq 50); do
        alive=0
        for daemon in slurmd slurmctld munged; do
            if [[ -f $dir/$daemon.pid ]] && kill -0 "$(cat "$dir/$daemon.pid")" 2>/dev/null; then
                alive=1
            fi
        done
        [[ $alive == 0 ]] && exit 0
        sleep 0.1
    done
    ;;
logs)
    for log in munged.log slurmctld.log slurmd.log; do
        echo "--- $log (last 40 lines)"
        tail -n 40 "$dir/$log" 2>/dev/null || echo "(none)"
    done
    ;;
*)
    echo "usage: local-cluster.sh start|stop|logs DIR" >&2
    exit 2
    ;;
esac
