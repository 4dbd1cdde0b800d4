#!/bin/sh
# Stops what start_cluster.sh DIR started: its jobs, every slurmd, slurmctld and
# munged it recorded in DIR/pids (by pid, SIGTERM then SIGKILL), then removes the
# mlcs- namespaces (and any process of a job left in them). Safe to run twice.
# Usage: stop_cluster.sh DIR
dir="$1"
here="$(cd "$(dirname "$0")" && pwd)"
if [ -f "$dir/slurm.conf" ]; then
  SLURM_CONF="$dir/slurm.conf" timeout 10 scancel --quiet --full --user=root 2> /dev/null
fi
if [ -f "$dir/pids" ]; then
  pids="$(cat "$dir/pids")"
  # The daemons in reverse order of their start: the slurmds, slurmctld, munged last.
  for p in $(echo "$pids" | sed -n '1!G;h;$p'); do kill "$p" 2> /dev/null; done
  i=0
  while [ "$i" -lt 50 ]; do
    left=""
    for p in $pids; do kill -0 "$p" 2> /dev/null && left="$left $p"; done
    [ -z "$left" ] && break
    sleep 0.2
    i=$((i + 1))
  done
  for p in $pids; do kill -9 "$p" 2> /dev/null; done
  rm -f "$dir/pids"
fi
"$here/../netns/teardown_hosts.sh" mlcs-
exit 0
