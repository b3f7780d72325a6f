#!/usr/bin/env bash
# A real single-node SLURM cluster on this machine, for the SLURM sweep test (CI) and for
# trying `sweep --slurm` by hand: munged, slurmctld and slurmd from Debian's packages,
# no systemd, no cgroups, no accounting database.
#
#   tools/slurm/cluster.sh up      # installs the packages if missing (root + apt-get), starts it
#   tools/slurm/cluster.sh down    # cancels every job, then stops the daemons
#
# State lives in $SLURM_STATE (default /tmp/foosball-slurm). The node offers the machine's
# cores; `sbatch`, `squeue`, `scancel` and `scontrol` then work as on any cluster.
set -euo pipefail
state=${SLURM_STATE:-/tmp/foosball-slurm}
conf=/etc/slurm/slurm.conf

install() {
    if command -v slurmctld >/dev/null && command -v slurmd >/dev/null \
        && command -v sbatch >/dev/null && command -v munged >/dev/null; then
        return
    fi
    if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null; then
        echo "SLURM is missing and cannot be installed here: install slurmctld slurmd slurm-client munge" >&2
        exit 1
    fi
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        slurmctld slurmd slurm-client munge >/dev/null
}

up() {
    install
    local host cpus mem
    host=$(hostname -s)
    cpus=$(nproc)
    mem=$(($(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 - 512))
    mkdir -p "$state"/{ctld,d,log} /etc/slurm /run/munge /var/lib/munge /var/log/munge
    # munged refuses a socket directory that others can write; 755 is what it accepts.
    chmod 755 /run/munge
    if [ ! -s /etc/munge/munge.key ]; then
        mkdir -p /etc/munge
        dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key 2>/dev/null
    fi
    chown -R munge:munge /etc/munge /run/munge /var/lib/munge /var/log/munge 2>/dev/null || true
    chmod 400 /etc/munge/munge.key
    pgrep -x munged >/dev/null || runuser -u munge -- munged 2>/dev/null || munged --force
    # Named with 127.0.0.1 so that nothing needs name resolution; linuxproc and task/none
    # need no cgroups; jobcomp/filetxt records exit codes without an accounting daemon.
    cat >"$conf" <<CONF
ClusterName=foosball
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/d
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/log/slurmctld.log
SlurmdLogFile=$state/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
JobRequeue=1
MinJobAge=600
KillWait=30
JobCompType=jobcomp/filetxt
JobCompLoc=$state/jobcomp.txt
AccountingStorageType=accounting_storage/none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=main Nodes=$host Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
CONF
    pgrep -x slurmctld >/dev/null || slurmctld
    pgrep -x slurmd >/dev/null || slurmd
    for _ in $(seq 1 60); do
        if sinfo -h -o '%T' 2>/dev/null | grep -qx idle; then
            echo "SLURM up: node $host, $cpus CPUs, partition main (state in $state)"
            return
        fi
        sleep 1
    done
    echo "SLURM did not come up; its logs:" >&2
    tail -n 20 "$state"/log/*.log >&2 || true
    exit 1
}

down() {
    # Jobs first: steps of a job outlive stopped daemons.
    scancel --full --user="$(id -un)" 2>/dev/null || true
    for _ in $(seq 1 30); do
        [ -z "$(squeue -h 2>/dev/null)" ] && break
        sleep 1
    done
    pkill -x slurmd 2>/dev/null || true
    pkill -x slurmctld 2>/dev/null || true
    echo "SLURM down"
}

case "${1:-}" in
    up) up ;;
    down) down ;;
    *) echo "usage: $0 up|down" >&2; exit 2 ;;
esac
