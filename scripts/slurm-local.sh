#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for `vsd farm` tests and trying the farm
# workflow without a real farm (docs/farm.md).
#
#   scripts/slurm-local.sh start [STATE_DIR]   start munged, slurmctld, slurmd; wait until
#                                              the node is idle (does nothing if running)
#   scripts/slurm-local.sh stop [STATE_DIR]    cancel its jobs, stop exactly those daemons
#   scripts/slurm-local.sh status [STATE_DIR]  say whether it runs; exit 0 if it does
#
# Everything lives in STATE_DIR (default ${TMPDIR:-/tmp}/vsd-slurm): munge key and socket,
# slurm.conf, spool folders, logs, pid files. Nothing under /etc is touched, so clients
# need SLURM_CONF=STATE_DIR/slurm.conf; `start` prints the export line. Needs root
# (slurmd launches jobs as their submitter; munged runs as user munge) and the Debian
# packages slurm-wlm and munge. Ports: slurmctld on the first of $VSD_SLURM_PORT (default
# 6817), +2, +4... whose pair (slurmctld, slurmd = +1) is free when the state folder is new,
# so two clusters in two state folders can run side by side.
set -euo pipefail

cmd=${1:-}
state=${2:-${TMPDIR:-/tmp}/vsd-slurm}

die() { echo "slurm-local: $*" >&2; exit 1; }

case "$cmd" in start|stop|status) ;; *)
  echo "usage: $0 start|stop|status [STATE_DIR]" >&2; exit 2 ;;
esac
mkdir -p "$state" 2>/dev/null || true
state=$(cd "$state" 2>/dev/null && pwd) || die "cannot use state folder '${2:-}'"
conf=$state/slurm.conf
export SLURM_CONF=$conf

# The pid in FILE if that process is still the daemon NAME (a pid file can outlive its
# process, and the pid be reused by something else that must not be killed).
live_pid() {
  local file=$1 name=$2 pid
  [ -r "$file" ] || return 1
  pid=$(tr -dc 0-9 < "$file")
  [ -n "$pid" ] && [ -r "/proc/$pid/comm" ] && [ "$(cat "/proc/$pid/comm")" = "$name" ] || return 1
  echo "$pid"
}

# The node takes jobs: idle on a fresh start, mixed or allocated when jobs already run.
node_up() { sinfo -h -N -o '%T' 2>/dev/null | grep -Eqx 'idle|mixed|allocated'; }

status() {
  local all=0 d f
  for d in munged:munge/munged.pid slurmctld:slurmctld.pid slurmd:slurmd.pid; do
    f=$state/${d#*:}
    if pid=$(live_pid "$f" "${d%%:*}"); then echo "${d%%:*}: running (pid $pid)"
    else echo "${d%%:*}: not running"; all=1; fi
  done
  [ "$all" -eq 0 ] && echo "node: $(sinfo -h -N -o '%N %T' 2>/dev/null || echo 'not answering')"
  return $all
}

# Stop the daemon whose pid file is FILE, if it is still that daemon; wait for it to go.
stop_daemon() {
  local file=$1 name=$2 pid
  pid=$(live_pid "$file" "$name") || return 0
  kill -TERM "$pid" 2>/dev/null || return 0
  for _ in $(seq 50); do [ -d "/proc/$pid" ] || break; sleep 0.1; done
  if [ -d "/proc/$pid" ]; then kill -KILL "$pid" 2>/dev/null || true; fi
  rm -f "$file"
  echo "slurm-local: stopped $name (pid $pid)"
}

stop() {
  # Jobs first: slurmstepd processes outlive slurmd, and only slurmctld can end them cleanly.
  if live_pid "$state/slurmctld.pid" slurmctld >/dev/null; then
    local ids
    ids=$(squeue -h -o %i 2>/dev/null || true)
    # shellcheck disable=SC2086 # one job id per word
    [ -z "$ids" ] || scancel --quiet $ids 2>/dev/null || true
    for _ in $(seq 50); do [ -z "$(squeue -h -o %i 2>/dev/null)" ] && break; sleep 0.2; done
  fi
  stop_daemon "$state/slurmd.pid" slurmd
  stop_daemon "$state/slurmctld.pid" slurmctld
  stop_daemon "$state/munge/munged.pid" munged
}

# Something listens on 127.0.0.1:PORT.
port_busy() { (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }

write_conf() {
  local host node port=${VSD_SLURM_PORT:-6817}
  for _ in $(seq 20); do
    port_busy "$port" || port_busy $((port + 1)) || break
    port=$((port + 2))
  done
  host=$(hostname -s)
  # slurmd -C prints this machine's node line (CPUs, sockets, cores, RealMemory) as Slurm
  # detects it; a hand-written line that claims more than that would leave the node invalid.
  node=$(slurmd -C 2>/dev/null | grep '^NodeName=' || true)
  [ -n "$node" ] || node="NodeName=$host CPUs=$(nproc) RealMemory=$(free -m | awk '/^Mem:/ {print $2}')"
  cat > "$conf" <<EOF
# One-node cluster of scripts/slurm-local.sh; state in $state.
ClusterName=vsdlocal
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
AuthType=auth/munge
AuthInfo=socket=$state/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/spool
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/slurmctld.log
SlurmdLogFile=$state/slurmd.log
# No cgroups (containers, no systemd): track job processes by their parent pids.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
SwitchType=switch/none
ReturnToService=2
# One CPU per task, so array tasks share the node.
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
# Let a cancelled task's processes go quickly (tests kill tasks on purpose).
KillWait=5
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
}

start_munge() {
  local m=$state/munge
  live_pid "$m/munged.pid" munged >/dev/null && return 0
  # munged refuses a key or socket folder that others could write to, and runs as munge.
  mkdir -p "$m"
  chown munge:munge "$m" && chmod 0755 "$m"
  if [ ! -s "$m/munge.key" ]; then
    runuser -u munge -- mungekey --create --keyfile="$m/munge.key" \
      || die "mungekey could not create $m/munge.key"
  fi
  runuser -u munge -- munged --socket="$m/munge.socket" --key-file="$m/munge.key" \
    --pid-file="$m/munged.pid" --log-file="$m/munged.log" --seed-file="$m/munged.seed" \
    || die "munged did not start (see $m/munged.log)"
}

start() {
  [ "$(id -u)" -eq 0 ] || die "needs root (slurmd starts jobs as their users)"
  for b in munged mungekey slurmctld slurmd sinfo; do
    command -v "$b" >/dev/null || die "$b not found: install the Debian packages slurm-wlm and munge"
  done
  if live_pid "$state/slurmctld.pid" slurmctld >/dev/null && live_pid "$state/slurmd.pid" slurmd >/dev/null \
     && node_up; then
    echo "slurm-local: already running; export SLURM_CONF=$conf"
    return 0
  fi
  mkdir -p "$state/ctld" "$state/spool"
  chmod 0755 "$state" # munged runs as user munge and must reach its folder inside
  [ -s "$conf" ] || write_conf
  start_munge
  if ! live_pid "$state/slurmctld.pid" slurmctld >/dev/null; then
    slurmctld -f "$conf" || die "slurmctld did not start (see $state/slurmctld.log)"
  fi
  if ! live_pid "$state/slurmd.pid" slurmd >/dev/null; then
    slurmd -f "$conf" || die "slurmd did not start (see $state/slurmd.log)"
  fi
  for _ in $(seq 60); do node_up && break; sleep 0.5; done
  node_up || { tail -n 5 "$state/slurmctld.log" "$state/slurmd.log" >&2 || true
                 die "the node did not come up within 30 s"; }
  echo "slurm-local: node $(hostname -s) up; export SLURM_CONF=$conf"
}

"$cmd"
