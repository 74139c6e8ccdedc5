#!/usr/bin/env bash
# A one-node Slurm cluster on localhost, for trying examples/slurm/ and for the
# Slurm test (tests/slurm.rs). Debian's slurm-wlm and munge
# (`apt-get install -y slurm-wlm munge`); run as root. Everything lives in STATE_DIR
# (configuration, munge key and socket, spool, logs): nothing under /etc is touched,
# and the daemons it starts are the only ones `stop` ends (by their pid files).
#
#   examples/slurm/local-cluster.sh start STATE_DIR [PORT]   # prints `export SLURM_CONF=...`
#   examples/slurm/local-cluster.sh stop STATE_DIR
#
# slurmctld + slurmd on 127.0.0.1 (ports PORT and PORT+1, default 6817/6818; a port
# already taken is named before anything starts, with a free PORT to use instead),
# ProctrackType=proctrack/linuxproc and TaskPlugin=task/none (no cgroups needed),
# one partition `bpins` with this machine's CPUs. Starts in a few seconds.
set -euo pipefail

cmd="${1:-}"
state="${2:-}"
if [ -z "$cmd" ] || [ -z "$state" ]; then
    echo "usage: $0 start|stop STATE_DIR [PORT]" >&2
    exit 2
fi
mkdir -p "$state"
state="$(cd "$state" && pwd)"
conf="$state/slurm.conf"

stop() {
    for f in "$state/slurmd.pid" "$state/slurmctld.pid" "$state/munged.pid"; do
        if [ -s "$f" ]; then
            pid="$(cat "$f")"
            if kill -0 "$pid" 2>/dev/null; then
                kill "$pid" 2>/dev/null || true
                for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
                kill -9 "$pid" 2>/dev/null || true
            fi
            rm -f "$f"
        fi
    done
}

case "$cmd" in
stop)
    stop
    echo "stopped the cluster in $state" >&2
    exit 0
    ;;
start) ;;
*)
    echo "usage: $0 start|stop STATE_DIR [PORT]" >&2
    exit 2
    ;;
esac

port="${3:-6817}"
case "$port" in
'' | *[!0-9]*)
    echo "error: PORT must be a number (1024-65534; the cluster uses PORT and PORT+1), not \`$port\`" >&2
    exit 2
    ;;
esac
if [ "$port" -lt 1024 ] || [ "$port" -gt 65534 ]; then
    echo "error: PORT $port is outside 1024-65534 (the cluster uses PORT and PORT+1)" >&2
    exit 2
fi
# Both ports free before anything starts: a daemon that cannot bind would only say so
# in its log, after a 20 s wait for a node that never comes up.
for p in "$port" "$((port + 1))"; do
    if [ "$p" = "$port" ]; then who=slurmctld; else who=slurmd; fi
    if (exec 3<>"/dev/tcp/127.0.0.1/$p") 2>/dev/null; then
        free=""
        for try in $(seq $((port + 2)) 2 $((port + 200))); do
            if ! (exec 3<>"/dev/tcp/127.0.0.1/$try") 2>/dev/null && ! (exec 3<>"/dev/tcp/127.0.0.1/$((try + 1))") 2>/dev/null; then
                free="$try"
                break
            fi
        done
        echo "error: port $p (for $who) is already taken on this machine (another Slurm, or an earlier cluster still running; \`ss -ltnp 'sport = :$p'\` shows which process)." >&2
        echo "  choose other ports with the third argument (the cluster uses PORT and PORT+1)${free:+, e.g. $free: $0 start $state $free}" >&2
        exit 1
    fi
done
for b in munged slurmctld slurmd sbatch sinfo; do
    if ! command -v "$b" >/dev/null 2>&1 && [ ! -x "/usr/sbin/$b" ]; then
        echo "error: $b not found; install Debian's slurm-wlm and munge (apt-get install -y slurm-wlm munge)" >&2
        exit 1
    fi
done
if [ "$(id -u)" != 0 ]; then
    echo "error: the local cluster runs its daemons as root" >&2
    exit 1
fi
export PATH="$PATH:/usr/sbin"
stop # a previous run's daemons in this state folder, if any

# munge: its own key, socket and logs in the state folder.
mkdir -p "$state/munge" "$state/ctld" "$state/spool" "$state/log"
chmod 700 "$state/munge"
if [ ! -s "$state/munge/munge.key" ]; then
    dd if=/dev/urandom of="$state/munge/munge.key" bs=1024 count=1 status=none
    chmod 400 "$state/munge/munge.key"
fi
munged --force --key-file="$state/munge/munge.key" --socket="$state/munge/munge.socket" \
    --pid-file="$state/munged.pid" --log-file="$state/log/munged.log" --seed-file="$state/munge/munge.seed"

host="$(hostname -s)"
node="$(slurmd -C | head -1)"
cpus="$(echo "$node" | sed -n 's/.*CPUs=\([0-9]*\).*/\1/p')"
cat >"$conf" <<CONF
# Written by examples/slurm/local-cluster.sh: a one-node cluster on localhost.
ClusterName=bpins-local
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$state/munge/munge.socket
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/spool
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/log/slurmctld.log
SlurmdLogFile=$state/log/slurmd.log
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
MinJobAge=600
KillWait=5
InactiveLimit=0
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=bpins Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$conf"
slurmctld -f "$conf" -c
slurmd -f "$conf"
for _ in $(seq 100); do
    if sinfo -h -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; then
        echo "export SLURM_CONF=$conf"
        exit 0
    fi
    sleep 0.2
done
echo "error: the node did not come up within 20 s; logs in $state/log" >&2
sinfo >&2 || true
tail -n 20 "$state/log/slurmctld.log" "$state/log/slurmd.log" >&2 || true
stop
exit 1
