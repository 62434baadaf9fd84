#!/usr/bin/env bash
# Installs (if needed) and starts a single-node Slurm on this machine, for lab's --executor slurm
# and its tests. No systemd: munged, slurmctld and slurmd are started by hand and their PIDs are
# recorded in $LAB_SLURM_DIR (default /tmp/lab-slurm), which this script owns; scripts/slurm-down.sh
# stops them by those PIDs. Prints the line to export SLURM_CONF (client commands need it).
#   source <(scripts/slurm-up.sh | grep ^export)     or: eval "$(scripts/slurm-up.sh | tail -1)"
set -euo pipefail
DIR=${LAB_SLURM_DIR:-/tmp/lab-slurm}

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v sbatch >/dev/null \
    || ! command -v munged >/dev/null; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >&2
    apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >&2
fi

mkdir -p "$DIR/state" "$DIR/spool" "$DIR/log"
# Already running (all recorded PIDs alive)? Then only print the export line.
all_alive() {
    grep -q slurmd "$1" || return 1
    while read -r _ pid; do kill -0 "$pid" 2>/dev/null || return 1; done <"$1"
}
if [ -f "$DIR/pids" ] && all_alive "$DIR/pids"; then
    echo "slurm already running (pids in $DIR/pids)" >&2
    echo "export SLURM_CONF=$DIR/slurm.conf"
    exit 0
fi
: >"$DIR/pids"

# munge: a key, /run/munge owned by munge, munged run as munge.
if [ ! -s /etc/munge/munge.key ]; then
    mkdir -p /etc/munge
    dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key status=none
fi
chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
mkdir -p /run/munge /var/lib/munge /var/log/munge
chown munge:munge /run/munge /var/lib/munge /var/log/munge
if [ ! -S /run/munge/munge.socket.2 ] || ! munge -n </dev/null >/dev/null 2>&1; then
    runuser -u munge -- /usr/sbin/munged --force
    for _ in $(seq 30); do [ -s /run/munge/munged.pid ] && break; sleep 0.1; done
    echo "munged $(cat /run/munge/munged.pid)" >>"$DIR/pids"   # ours: slurm-down stops it
fi

NODE=$(hostname -s)
# CPUs, sockets, cores from slurmd -C; memory a little under what exists.
read -r CPUS SOCKETS CORES THREADS < <(slurmd -C | head -1 | tr ' ' '\n' | awk -F= '
    $1=="CPUs"{c=$2} $1=="SocketsPerBoard"{s=$2} $1=="CoresPerSocket"{k=$2} $1=="ThreadsPerCore"{t=$2}
    END{print c, s, k, t}')
MEM=$(awk '/MemTotal/{printf "%d", $2/1024*0.9}' /proc/meminfo)
cat >"$DIR/slurm.conf" <<CONF
ClusterName=lab
SlurmctldHost=$NODE
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$DIR/jobcomp.txt
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerParameters=batch_sched_delay=0
MinJobAge=300
DefMemPerCPU=256
ReturnToService=2
NodeName=$NODE CPUs=$CPUS Sockets=$SOCKETS CoresPerSocket=$CORES ThreadsPerCore=$THREADS RealMemory=$MEM State=UNKNOWN
PartitionName=lab Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF=$DIR/slurm.conf

slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 50); do
    [ -s "$DIR/slurmctld.pid" ] && [ -s "$DIR/slurmd.pid" ] && break
    sleep 0.1
done
echo "slurmctld $(cat "$DIR/slurmctld.pid")" >>"$DIR/pids"
echo "slurmd $(cat "$DIR/slurmd.pid")" >>"$DIR/pids"

# Wait for the node to be idle.
for _ in $(seq 100); do
    state=$(sinfo -h -N -o %t 2>/dev/null | head -1 || true)
    [ "$state" = idle ] && break
    sleep 0.2
done
[ "$state" = idle ] || { echo "slurm node not idle (state: ${state:-none}); see $DIR/log" >&2; exit 1; }
echo "slurm up: node $NODE, $CPUS CPUs, conf $SLURM_CONF" >&2
echo "export SLURM_CONF=$SLURM_CONF"
