#!/bin/sh
# Starts a Slurm cluster on this machine for the Slurm test: munged, slurmctld and
# one slurmd per node, every node a network namespace made by
# tests/netns/setup_hosts.sh with the tag mlcs- (mlcs-h1..N at 10.78.0.1..N, the
# controller on the bridge at 10.78.0.254). Each slurmd runs in its node's network
# namespace (nsenter: `ip netns exec` would remount /sys and hide the cgroup
# mounts slurmd checks) and its own UTS namespace named after the node, so the
# job's processes see the node's name and address as on separate machines.
# Everything (configuration, keys, state, logs, pid files) lives in DIR; clients
# use it through SLURM_CONF=DIR/slurm.conf. Stop it with stop_cluster.sh DIR.
# Exit code 77 with the reason on stderr (and in DIR/skip_reason) when the cluster
# cannot be started here (not root, munged refused to start); the test skips then.
# A program scripts/setup.sh installs that is missing, or setup_hosts.sh failing, is
# the project's own failure: exit code 1 with the reason, and the test fails.
# Usage: start_cluster.sh DIR [NODES=2] [CPUS=2]
set -u
dir="$1"
nodes="${2:-2}"
cpus="${3:-2}"
here="$(cd "$(dirname "$0")" && pwd)"
netns="$here/../netns"
mkdir -p "$dir" && dir="$(cd "$dir" && pwd)"

skip() {
  echo "start_cluster.sh: $*" >&2
  echo "$*" > "$dir/skip_reason"
  "$here/stop_cluster.sh" "$dir" > /dev/null 2>&1
  exit 77
}
fail() {
  echo "start_cluster.sh: $*" >&2
  "$here/stop_cluster.sh" "$dir" > /dev/null 2>&1
  exit 1
}
[ "$(id -u)" = 0 ] || skip "needs root (network namespaces, slurmd)"
for p in munged munge slurmctld slurmd sbatch scontrol sinfo nsenter unshare ip; do
  command -v "$p" > /dev/null || fail "$p is not installed: run scripts/setup.sh (it installs slurm-wlm, munge, iproute2)"
done
"$netns/setup_hosts.sh" "$nodes" mlcs- 10.78.0 || fail "cannot make the network namespaces: tests/netns/setup_hosts.sh failed (above)"

# munged refuses a socket folder that others cannot traverse, and a key others can read.
chmod 711 "$dir"
mkdir -p "$dir/state" "$dir/spool"
head -c 1024 /dev/urandom > "$dir/munge.key" && chmod 400 "$dir/munge.key"
nice -n 10 munged -F --key-file="$dir/munge.key" --socket="$dir/munge.sock" --pid-file="$dir/munged.pid" \
  --log-file="$dir/munged.log" --seed-file="$dir/munged.seed" > "$dir/munged.out" 2>&1 &
echo $! > "$dir/pids"
i=0
until munge -S "$dir/munge.sock" -n 2> /dev/null | unmunge -S "$dir/munge.sock" > /dev/null 2>&1; do
  i=$((i + 1))
  [ "$i" -le 50 ] || skip "munged did not start: $(tail -n 3 "$dir/munged.out" | tr '\n' ' ')"
  sleep 0.2
done

ctl="$(hostname -s)"
{
  echo "# Written by tests/slurm/start_cluster.sh: a test cluster of $nodes network-namespace nodes."
  echo "ClusterName=mlcgtest"
  echo "SlurmctldHost=$ctl(10.78.0.254)"
  echo "SlurmctldPort=6917"  # not the default ports: a site's own Slurm on this machine is left alone
  echo "SlurmdPort=6918"
  echo "SlurmUser=root"
  echo "SlurmdUser=root"
  echo "AuthType=auth/munge"
  echo "CredType=cred/munge"
  echo "AuthInfo=socket=$dir/munge.sock"
  echo "StateSaveLocation=$dir/state"
  echo "SlurmdSpoolDir=$dir/spool/%n"
  echo "SlurmctldPidFile=$dir/slurmctld.pid"
  echo "SlurmdPidFile=$dir/slurmd-%n.pid"
  echo "SlurmctldLogFile=$dir/slurmctld.log"
  echo "SlurmdLogFile=$dir/slurmd-%n.log"
  echo "ProctrackType=proctrack/linuxproc"
  echo "TaskPlugin=task/none"
  echo "SelectType=select/cons_tres"
  echo "SelectTypeParameters=CR_CPU"
  echo "SwitchType=switch/none"
  echo "MpiDefault=none"
  echo "JobCompType=jobcomp/none"
  echo "AccountingStorageType=accounting_storage/none"
  echo "JobAcctGatherType=jobacct_gather/none"
  echo "MailProg=/bin/true"
  echo "ReturnToService=2"
  echo "SlurmdParameters=config_overrides"  # CPUs=$cpus per node whatever this machine has
  echo "SlurmctldDebug=info"
  echo "SlurmdDebug=info"
  k=1
  while [ "$k" -le "$nodes" ]; do
    echo "NodeName=mlcs-h$k NodeAddr=10.78.0.$k CPUs=$cpus State=UNKNOWN"
    k=$((k + 1))
  done
  echo "PartitionName=mlcg Nodes=mlcs-h[1-$nodes] Default=YES MaxTime=INFINITE State=UP"
} > "$dir/slurm.conf"
export SLURM_CONF="$dir/slurm.conf"

nice -n 10 slurmctld -D -f "$SLURM_CONF" > "$dir/slurmctld.out" 2>&1 &
echo $! >> "$dir/pids"
i=0
until scontrol ping 2> /dev/null | grep -q "is UP"; do
  i=$((i + 1))
  [ "$i" -le 75 ] || skip "slurmctld did not start: $(grep -i error "$dir/slurmctld.out" | tail -n 3 | tr '\n' ' ')"
  sleep 0.2
done
k=1
while [ "$k" -le "$nodes" ]; do
  h="mlcs-h$k"
  mkdir -p "$dir/spool/$h"
  nice -n 10 nsenter --net="/run/netns/$h" unshare --uts sh -c 'hostname "$0" && exec slurmd -D -N "$0" -f "$1"' \
    "$h" "$SLURM_CONF" > "$dir/slurmd-$h.out" 2>&1 &
  echo $! >> "$dir/pids"
  k=$((k + 1))
done
i=0
until [ "$(sinfo -h -N -o '%T' 2> /dev/null | grep -c '^idle$')" = "$nodes" ]; do
  i=$((i + 1))
  [ "$i" -le 150 ] || skip "the slurmd nodes did not come up idle ($(sinfo -h -N -o '%N %T %E' 2>&1 | tr '\n' ';')): \
$(cat "$dir"/slurmd-*.out 2> /dev/null | grep -i error | tail -n 3 | tr '\n' ' ')"
  sleep 0.2
done
echo "export SLURM_CONF=$SLURM_CONF" > "$dir/env"
