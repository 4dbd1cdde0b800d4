#!/bin/sh
# Removes what setup_hosts.sh made: the mlcg-h* namespaces (stopping any process
# left in them), the bridge and the /etc/hosts lines marked "# mlcg-netns".
# Safe to run when nothing is set up.
for h in $(ip netns list 2>/dev/null | awk '/^mlcg-h[0-9]+/ {print $1}'); do
  pids="$(ip netns pids "$h" 2>/dev/null)"
  [ -n "$pids" ] && kill -9 $pids 2>/dev/null
  ip netns del "$h"
done
ip link del mlcg-br0 2>/dev/null
if grep -q '# mlcg-netns$' /etc/hosts 2>/dev/null; then
  # /etc/hosts may be a bind mount (containers): rewrite it in place, never replace the file.
  grep -v '# mlcg-netns$' /etc/hosts > /tmp/mlcg-hosts.$$ && cat /tmp/mlcg-hosts.$$ > /etc/hosts
  rm -f /tmp/mlcg-hosts.$$
fi
exit 0
