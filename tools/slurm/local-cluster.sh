#!/usr/bin/env bash
# A single-node Slurm cluster on localhost, for testing the sbatch scripts of this folder end to
# end (tests/distributed/slurm.rs): installs Debian's slurm-wlm and munge when missing, writes a minimal
# slurm.conf (one CPU-only node, this machine, in partition "debug"), creates the munge key and
# starts munged, slurmctld and slurmd. Needs root (or sudo).
#
#   tools/slurm/local-cluster.sh start    # install if needed, configure, start; waits until sinfo answers
#   tools/slurm/local-cluster.sh stop     # stop the three daemons it started
#   tools/slurm/local-cluster.sh status   # sinfo
#
# Exit status 0 when the cluster answers, 1 when it could not be installed or started.
set -euo pipefail
action=${1:-start}
sudo=""; [ "$(id -u)" -eq 0 ] || sudo=sudo
conf_dir=/etc/slurm
state=/var/spool/wavetrace-slurm
run=/run/wavetrace-slurm

stop() {
    for pidfile in "$run/slurmd.pid" "$run/slurmctld.pid" /run/munge/munged.pid; do
        if [ -f "$pidfile" ]; then
            $sudo kill "$(cat "$pidfile")" 2>/dev/null || true
            $sudo rm -f "$pidfile"
        fi
    done
}

case "$action" in
    stop) stop; exit 0 ;;
    status) exec sinfo ;;
    start) ;;
    *) echo "usage: $0 start|stop|status" >&2; exit 2 ;;
esac

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    if ! command -v apt-get >/dev/null; then
        echo "local-cluster: slurm-wlm and munge are not installed and there is no apt-get" >&2
        exit 1
    fi
    $sudo apt-get update -qq
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null
fi

# Already up (started earlier)?
if timeout 5 sinfo -h >/dev/null 2>&1 && timeout 5 scontrol ping 2>/dev/null | grep -q UP; then
    echo "local-cluster: already running"
    sinfo
    exit 0
fi
stop

$sudo mkdir -p "$conf_dir" "$state/ctld" "$state/d" "$run" /var/log/slurm /etc/munge /var/lib/munge /var/log/munge /run/munge
# munge: one shared key (this one node); the daemon refuses keys others can read.
if [ ! -s /etc/munge/munge.key ]; then
    $sudo mungekey --create --keyfile=/etc/munge/munge.key 2>/dev/null ||
        $sudo dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
fi
munge_user=root
if id munge >/dev/null 2>&1; then munge_user=munge; fi
$sudo chown -R "$munge_user" /etc/munge /var/lib/munge /var/log/munge /run/munge
$sudo chmod 0700 /etc/munge /var/lib/munge /var/log/munge
$sudo chmod 0400 /etc/munge/munge.key
$sudo chmod 0755 /run/munge
# munged writes /run/munge/munged.pid; one already running (and answering) is kept.
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
    if [ "$munge_user" = root ]; then
        $sudo munged --force
    elif [ -z "$sudo" ]; then
        runuser -u munge -- munged
    else
        sudo -u munge munged
    fi
fi
for _ in $(seq 50); do munge -n >/dev/null 2>&1 && break; sleep 0.1; done
if ! munge -n | unmunge >/dev/null 2>&1; then
    echo "local-cluster: munged did not start" >&2
    exit 1
fi

host=$(hostname -s)
# The node as slurmd sees it (CPUs, sockets, cores, threads, memory), minus the memory line so
# that jobs are not refused for memory the container reports differently.
node=$(slurmd -C | head -1 | sed -e 's/ RealMemory=[0-9]*//' -e 's/^NodeName=[^ ]*//')
$sudo tee "$conf_dir/slurm.conf" >/dev/null <<CONF
# Written by wavetrace tools/slurm/local-cluster.sh: one CPU-only node on localhost.
ClusterName=wavetrace-local
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/d
SlurmctldPidFile=$run/slurmctld.pid
SlurmdPidFile=$run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
# Finished jobs stay visible to scontrol for 10 minutes.
MinJobAge=600
NodeName=$host$node State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
# Debian's slurm reads /etc/slurm/slurm.conf; cgroup.conf is not needed with proctrack/linuxproc.
$sudo slurmctld -c
for _ in $(seq 50); do timeout 2 scontrol ping 2>/dev/null | grep -q UP && break; sleep 0.2; done
$sudo slurmd
for _ in $(seq 100); do
    if sinfo -h -o %t 2>/dev/null | grep -qE '^(idle|mix|alloc)'; then
        echo "local-cluster: up"
        sinfo
        exit 0
    fi
    sleep 0.2
done
echo "local-cluster: the node did not come up; see /var/log/slurm/" >&2
sinfo >&2 || true
exit 1
