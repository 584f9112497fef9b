#!/usr/bin/env bash
# A one-node Slurm cluster for tests, without systemd:
#   cluster.sh up RUN [Key=Value ...]   (extra slurm.conf lines, e.g. MaxArraySize=3)
#   cluster.sh down RUN
# Everything (config, state, sockets, logs) lives under RUN; nothing system-wide is
# touched except running munged, slurmctld and slurmd (Debian's packages) as root.
# Clients find the cluster with SLURM_CONF=RUN/slurm.conf. The ports are picked
# free at start, so two clusters (two checkouts testing at once) do not collide.
set -euo pipefail
export PATH=$PATH:/usr/sbin:/sbin
cmd=${1:?usage: cluster.sh up RUN [Key=Value ...] | down RUN}
RUN=$(realpath -m "${2:?usage: cluster.sh up RUN [Key=Value ...] | down RUN}")
shift 2
CONF=$RUN/slurm.conf
export SLURM_CONF=$CONF

alive() {  # pid alive and not a zombie (PID 1 may reap late)
  local pid=$1
  [ -n "$pid" ] && [ -r "/proc/$pid/stat" ] && [ "$(awk '{print $3}' "/proc/$pid/stat")" != Z ]
}
pid_of() { [ -s "$1" ] && cat "$1" || true; }
stop_pidfile() {
  local f=$1 name=$2 pid
  pid=$(pid_of "$f")
  if [ -n "$pid" ] && alive "$pid" && grep -qx "$name" "/proc/$pid/comm"; then
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 100); do alive "$pid" || break; sleep 0.1; done
    if alive "$pid"; then kill -KILL "$pid" 2>/dev/null || true; fi
  fi
  rm -f "$f"
}
die() { echo "cluster.sh: $*" >&2; exit 1; }
# Waits up to 60 s for `check` while the daemon of pid file $2 lives.
wait_for() {
  local what=$1 pidfile=$2 log=$3 check=$4
  for _ in $(seq 600); do
    if eval "$check"; then return 0; fi
    local pid; pid=$(pid_of "$pidfile")
    if [ -n "$pid" ] && ! alive "$pid"; then die "$what died (log: $log)"; fi
    sleep 0.1
  done
  die "$what did not come up in 60 s (log: $log)"
}
free_port() {  # a port nothing listens on (bash's /dev/tcp: no extra tool)
  local p
  for _ in $(seq 50); do
    p=$(( 20000 + RANDOM % 30000 ))
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$p") 2>/dev/null; then echo "$p"; return; fi
  done
  die "no free port found"
}

if [ "$cmd" = down ]; then
  if [ -f "$CONF" ] && alive "$(pid_of "$RUN/slurmctld.pid")"; then
    scancel --quiet --user="$(id -un)" 2>/dev/null || true
    for _ in $(seq 150); do
      out=$(squeue -h 2>/dev/null) || break
      [ -z "$out" ] && break
      sleep 0.2
    done
  fi
  stop_pidfile "$RUN/slurmd.pid" slurmd
  stop_pidfile "$RUN/slurmctld.pid" slurmctld
  stop_pidfile "$RUN/munge/munged.pid" munged
  exit 0
fi
[ "$cmd" = up ] || die "unknown command $cmd (up or down)"

rm -rf "$RUN"
mkdir -p "$RUN/munge" "$RUN/state" "$RUN/spool" "$RUN/log"
# The daemons' users (munge, slurm) must reach their files under RUN.
chmod 755 "$RUN" "$RUN/munge"
chown munge:munge "$RUN/munge"
chown slurm:slurm "$RUN/state" "$RUN/log"
[ -f /etc/munge/munge.key ] || mungekey --create
setpriv --reuid=munge --regid=munge --init-groups /usr/sbin/munged --socket="$RUN/munge/munge.socket.2" \
  --pid-file="$RUN/munge/munged.pid" --log-file="$RUN/munge/munged.log" --seed-file="$RUN/munge/munged.seed"
wait_for munged "$RUN/munge/munged.pid" "$RUN/munge/munged.log" '[ -S "$RUN/munge/munge.socket.2" ]'

node=$(slurmd -C | head -1)
cpus=$(sed -n 's/.*CPUs=\([0-9]*\).*/\1/p' <<<"$node")
mem=$(sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' <<<"$node")
ctld_port=$(free_port)
slurmd_port=$(free_port)
[ "$slurmd_port" != "$ctld_port" ] || slurmd_port=$(( ctld_port + 1 ))
{
  cat <<CONF
ClusterName=atacomci
SlurmctldHost=localhost
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=slurm
AuthType=auth/munge
# cred_expire is also how long a requeued job waits before it may start again (default 120 s).
AuthInfo=socket=$RUN/munge/munge.socket.2,cred_expire=10
StateSaveLocation=$RUN/state
SlurmdSpoolDir=$RUN/spool
SlurmctldPidFile=$RUN/slurmctld.pid
SlurmdPidFile=$RUN/slurmd.pid
SlurmctldLogFile=$RUN/log/slurmctld.log
SlurmdLogFile=$RUN/slurmd.log
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/filetxt
JobCompLoc=$RUN/log/jobcomp.txt
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SwitchType=switch/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerParameters=batch_sched_delay=0,sched_min_interval=0
ReturnToService=2
KillWait=10
MailProg=/bin/true
CONF
  for line in "$@"; do echo "$line"; done
  echo "NodeName=localhost CPUs=$cpus RealMemory=$mem State=UNKNOWN"
  echo "PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP"
} > "$CONF"
touch "$RUN/slurmctld.pid"; chown slurm:slurm "$RUN/slurmctld.pid"
slurmctld -f "$CONF"
wait_for slurmctld "$RUN/slurmctld.pid" "$RUN/log/slurmctld.log" 'scontrol ping 2>/dev/null | grep -q UP'
slurmd -f "$CONF" -N localhost
wait_for slurmd "$RUN/slurmd.pid" "$RUN/slurmd.log" '[ "$(sinfo -h -n localhost -o %T 2>/dev/null)" = idle ]'
echo "cluster.sh: up (SLURM_CONF=$CONF, $cpus CPUs, ports $ctld_port/$slurmd_port, $(slurmctld -V))"
