#!/usr/bin/env bash
# A one-node Slurm cluster for tests, without systemd: cluster.sh up RUN | down RUN.
# Everything (config, state, sockets, logs) lives under RUN; nothing system-wide is touched
# except running munged, slurmctld and slurmd (as in Debian's packages).
set -euo pipefail
cmd=${1:?usage: cluster.sh up|down RUN}
RUN=$(realpath -m "${2:?usage: cluster.sh up|down RUN}")
CONF=$RUN/slurm.conf
export SLURM_CONF=$CONF

alive() {  # pid alive and not a zombie
  local pid=$1
  [ -n "$pid" ] && [ -r /proc/$pid/stat ] && [ "$(awk '{print $3}' /proc/$pid/stat)" != Z ]
}
stop_pidfile() {
  local f=$1 name=$2
  [ -f "$f" ] || return 0
  local pid; pid=$(cat "$f")
  if alive "$pid" && grep -q "$name" /proc/$pid/comm; then
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 100); do alive "$pid" || break; sleep 0.1; done
    alive "$pid" && kill -KILL "$pid" 2>/dev/null || true
  fi
  rm -f "$f"
}

if [ "$cmd" = down ]; then
  if [ -f "$RUN/slurmctld.pid" ]; then
    scancel --full --quiet --user="$(id -un)" 2>/dev/null || true
    for _ in $(seq 100); do [ -z "$(squeue -h 2>/dev/null)" ] && break; sleep 0.2; done
  fi
  stop_pidfile "$RUN/slurmd.pid" slurmd
  stop_pidfile "$RUN/slurmctld.pid" slurmctld
  stop_pidfile "$RUN/munge/munged.pid" munged
  exit 0
fi
[ "$cmd" = up ] || { echo "cluster.sh: unknown command $cmd" >&2; exit 2; }

rm -rf "$RUN"
mkdir -p "$RUN/munge" "$RUN/state" "$RUN/spool" "$RUN/log"
chown munge:munge "$RUN/munge"; chmod 700 "$RUN/munge"
chown slurm:slurm "$RUN/state" "$RUN/log"
[ -f /etc/munge/munge.key ] || mungekey --create
setpriv --reuid=munge --regid=munge --init-groups /usr/sbin/munged --socket="$RUN/munge/munge.socket.2" \
  --pid-file="$RUN/munge/munged.pid" --log-file="$RUN/munge/munged.log" --seed-file="$RUN/munge/munged.seed"
for _ in $(seq 100); do [ -S "$RUN/munge/munge.socket.2" ] && break; sleep 0.1; done

cpus=$(slurmd -C | sed -n 's/.*CPUs=\([0-9]*\).*/\1/p')
mem=$(slurmd -C | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p')
cat > "$CONF" <<CONF
ClusterName=atacomci
SlurmctldHost=localhost
SlurmUser=slurm
AuthType=auth/munge
AuthInfo=socket=$RUN/munge/munge.socket.2
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
NodeName=localhost CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
touch "$RUN/slurmctld.pid"; chown slurm:slurm "$RUN/slurmctld.pid"
slurmctld -f "$CONF"
for i in $(seq 600); do
  scontrol ping 2>/dev/null | grep -q UP && break
  [ "$i" = 600 ] && { echo "cluster.sh: slurmctld did not come up (log: $RUN/log/slurmctld.log)" >&2; exit 1; }
  sleep 0.1
done
slurmd -f "$CONF" -N localhost
for i in $(seq 600); do
  [ "$(sinfo -h -n localhost -o %T 2>/dev/null)" = idle ] && break
  [ "$i" = 600 ] && { echo "cluster.sh: the node did not become idle (log: $RUN/slurmd.log)" >&2; exit 1; }
  sleep 0.1
done
echo "cluster.sh: up (SLURM_CONF=$CONF, $cpus CPUs)"
