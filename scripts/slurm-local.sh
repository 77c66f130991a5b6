#!/usr/bin/env bash
# A one-node Slurm on this machine, for checking the batch scripts the way a lab runs them:
#
#   scripts/slurm-local.sh start    install Slurm and munge from Debian if missing, write the
#                                   config, start munged, slurmctld and slurmd, wait for the
#                                   node to be idle (at most 60 s)
#   scripts/slurm-local.sh stop     stop the three daemons
#   scripts/slurm-local.sh status   print sinfo
#
# The daemons are started by hand, not through systemd: CI and the development machines are
# containers without an init system, and we are root there. `start` is idempotent: a daemon
# already running is left alone. Everything the daemons write (state, spool, logs, pid files)
# lives under $SLURM_LOCAL_DIR (default /var/spool/slurm-local); the config goes to
# /etc/slurm/slurm.conf, where sbatch and sinfo look without any environment variable.
set -euo pipefail

base="${SLURM_LOCAL_DIR:-/var/spool/slurm-local}"
conf=/etc/slurm/slurm.conf
marker="# Written by scripts/slurm-local.sh"
wait_s=60

die() {
    echo "slurm-local: $*" >&2
    exit 1
}

# The pid in a pid file, if that process is alive.
alive_pid() {
    local pid
    [[ -s "$1" ]] || return 1
    pid="$(cat "$1")"
    [[ "$pid" =~ ^[0-9]+$ ]] && kill -0 "$pid" 2>/dev/null && echo "$pid"
}

# Prints the last lines of a daemon's log and fails with one line naming it.
daemon_failed() {
    local name="$1" log="$2"
    if [[ -s "$log" ]]; then
        echo "--- last lines of $log" >&2
        tail -n 15 "$log" >&2
        echo "---" >&2
    fi
    die "$name did not stay up (log: $log)"
}

install_packages() {
    if command -v slurmctld >/dev/null && command -v slurmd >/dev/null &&
        command -v sbatch >/dev/null && command -v munged >/dev/null; then
        return
    fi
    [[ $EUID -eq 0 ]] || die "Slurm is not installed and installing it needs root"
    echo "slurm-local: installing slurmctld, slurmd, slurm-client and munge from Debian"
    export DEBIAN_FRONTEND=noninteractive
    local log
    log="$(mktemp)"
    # A fresh machine may have no package lists yet. apt's chatter goes to a log, shown on failure.
    if ! apt-get update -qq >"$log" 2>&1 ||
        ! apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >>"$log" 2>&1; then
        tail -n 20 "$log" >&2
        rm -f "$log"
        die "installing slurmctld, slurmd, slurm-client and munge with apt-get failed"
    fi
    rm -f "$log"
}

write_config() {
    local host cpus tmp
    host="$(hostname -s)"
    cpus="$(nproc)"
    mkdir -p /etc/slurm "$base/ctld" "$base/d" "$base/log"
    tmp="$(mktemp)"
    # select/cons_tres with CR_Core: each array task takes one core, so a 2-core node runs two
    # at once. The node line gives CPUs only, so Slurm counts each CPU as a core (slurmd logs
    # the real sockets and cores and carries on): with hyperthreads, one task per thread. No cgroups (containers rarely delegate them): processes are tracked through
    # /proc and tasks are not confined. No accounting database, so no sacct.
    cat >"$tmp" <<EOF
$marker for one node on this machine; rewritten by each start.
ClusterName=local
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$base/ctld
SlurmdSpoolDir=$base/d
SlurmctldPidFile=$base/slurmctld.pid
SlurmdPidFile=$base/slurmd.pid
SlurmctldLogFile=$base/log/slurmctld.log
SlurmdLogFile=$base/log/slurmd.log
SlurmctldPort=6817
SlurmdPort=6818
MpiDefault=none
# No mail on a test node; the default /bin/mail is absent and slurmctld logs an error.
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
SlurmdTimeout=60
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=1024 State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
    if [[ -f "$conf" ]] && ! head -n 1 "$conf" | grep -qF "$marker"; then
        rm -f "$tmp"
        die "$conf exists and was not written by this script; move it away first"
    fi
    if ! cmp -s "$tmp" "$conf" 2>/dev/null; then
        # Daemons running with another config would disagree with the new one.
        stop_daemons
        install -m 0644 "$tmp" "$conf"
    fi
    rm -f "$tmp"
}

munge_works() {
    munge -n 2>/dev/null | unmunge >/dev/null 2>&1
}

start_munge() {
    if munge_works; then
        return
    fi
    if [[ ! -s /etc/munge/munge.key ]]; then
        mkdir -p /etc/munge
        mungekey --create --keyfile=/etc/munge/munge.key 2>/dev/null ||
            dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
    fi
    # munged refuses a key, socket or log directory that others can write or that another user
    # owns; the run directory is normally made by systemd's tmpfiles.
    chown munge:munge /etc/munge /etc/munge/munge.key
    chmod 0700 /etc/munge
    chmod 0400 /etc/munge/munge.key
    mkdir -p /run/munge /var/log/munge /var/lib/munge
    chown munge:munge /run/munge /var/log/munge /var/lib/munge
    chmod 0755 /run/munge
    runuser -u munge -- /usr/sbin/munged ||
        daemon_failed munged /var/log/munge/munged.log
    for _ in $(seq 1 50); do
        munge_works && return
        sleep 0.2
    done
    daemon_failed munged /var/log/munge/munged.log
}

# Starts a Slurm daemon unless its pid file names a live process, and checks it stays up.
start_daemon() {
    local name="$1" pidfile="$base/$1.pid" log="$base/log/$1.log"
    if alive_pid "$pidfile" >/dev/null; then
        return
    fi
    rm -f "$pidfile"
    # Both daemonise themselves and write their pid file; a config error makes them exit at once.
    "/usr/sbin/$name" || daemon_failed "$name" "$log"
    for _ in $(seq 1 50); do
        alive_pid "$pidfile" >/dev/null && break
        sleep 0.2
    done
    sleep 1
    alive_pid "$pidfile" >/dev/null || daemon_failed "$name" "$log"
}

# The node registers a few seconds after slurmd starts; until then sinfo says unknown or down.
node_failed() {
    sinfo -R >&2 2>/dev/null || true
    tail -n 5 "$base/log/slurmd.log" >&2 2>/dev/null || true
    die "node $(hostname -s) is '$1', not idle (logs: $base/log)"
}

wait_idle() {
    local state="" host resumed=no
    host="$(hostname -s)"
    for ((i = 0; i < wait_s * 2; i++)); do
        state="$(sinfo -h -n "$host" -o %T 2>/dev/null | head -n 1)"
        case "$state" in
        idle | mixed | allocated | completing) return ;;
        # The controller keeps a drain across restarts (saved state): one left by an earlier
        # config, or by a job killed with the daemons. Resume it once; if the node drains again
        # the cause is still there.
        drain*)
            [[ $resumed == no ]] || node_failed "$state"
            resumed=yes
            scontrol update NodeName="$host" State=RESUME ||
                node_failed "$state (and scontrol could not resume it)"
            ;;
        # A config that claims more than the machine has: waiting will not help.
        inval) node_failed "$state" ;;
        esac
        for d in slurmctld slurmd; do
            alive_pid "$base/$d.pid" >/dev/null || daemon_failed "$d" "$base/log/$d.log"
        done
        sleep 0.5
    done
    node_failed "${state:-unknown} after ${wait_s} s"
}

stop_one() {
    local name="$1" pidfile="$2" pid
    pid="$(alive_pid "$pidfile")" || {
        rm -f "$pidfile"
        return 0
    }
    kill "$pid" 2>/dev/null || true
    for _ in $(seq 1 50); do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.2
    done
    if kill -0 "$pid" 2>/dev/null; then
        echo "slurm-local: $name ($pid) ignored SIGTERM for 10 s; sending SIGKILL" >&2
        kill -9 "$pid" 2>/dev/null || true
    fi
    rm -f "$pidfile"
}

# Jobs still running when slurmd stops would be left behind as orphans: cancel them first.
cancel_jobs() {
    local ids
    alive_pid "$base/slurmctld.pid" >/dev/null || return 0
    ids="$(squeue -h -o %A 2>/dev/null)" || return 0
    [[ -n "$ids" ]] || return 0
    echo "slurm-local: cancelling jobs $(echo "$ids" | tr '\n' ' ')"
    # shellcheck disable=SC2086 # one job id per word
    scancel $ids || true
    for _ in $(seq 1 30); do
        [[ -z "$(squeue -h -o %A 2>/dev/null)" ]] && return 0
        sleep 0.5
    done
    echo "slurm-local: jobs still listed after 15 s; stopping anyway" >&2
}

stop_daemons() {
    cancel_jobs
    stop_one slurmd "$base/slurmd.pid"
    stop_one slurmctld "$base/slurmctld.pid"
}

cmd="${1:-}"
case "$cmd" in
start)
    t0=$SECONDS
    install_packages
    write_config
    start_munge
    start_daemon slurmctld
    start_daemon slurmd
    wait_idle
    echo "slurm-local: node $(hostname -s) up ($(nproc) CPUs, partition debug) in $((SECONDS - t0)) s"
    ;;
stop)
    stop_daemons
    stop_one munged /run/munge/munged.pid
    echo "slurm-local: stopped"
    ;;
status)
    command -v sinfo >/dev/null || die "Slurm is not installed (run: $0 start)"
    sinfo
    ;;
*)
    echo "usage: $0 start|stop|status" >&2
    exit 2
    ;;
esac
