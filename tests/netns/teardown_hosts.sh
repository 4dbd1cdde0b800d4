#!/bin/sh
# Removes what setup_hosts.sh made: the mlcg-h* namespaces (stopping any process
# left in them), the bridge and the /etc/hosts lines marked "# mlcg-netns"; with
# TAG, the set setup_hosts.sh made with that tag. Safe to run when nothing is set up.
# Usage: teardown_hosts.sh [TAG=mlcg-]
tag="${1:-mlcg-}"
for h in $(ip netns list 2>/dev/null | awk -v p="^${tag}h[0-9]+" '$1 ~ p {print $1}'); do
  pids="$(ip netns pids "$h" 2>/dev/null)"
  [ -n "$pids" ] && kill -9 $pids 2>/dev/null
  ip netns del "$h"
done
ip link del "${tag}br0" 2>/dev/null
if grep -q "# ${tag}netns\$" /etc/hosts 2>/dev/null; then
  # /etc/hosts may be a bind mount (containers): rewrite it in place, never replace the file. grep -v exits 1
  # when no line is left (a chroot without an /etc/hosts of its own): that is no failure.
  { grep -v "# ${tag}netns\$" /etc/hosts || [ $? -eq 1 ]; } > /tmp/mlcg-hosts.$$ && cat /tmp/mlcg-hosts.$$ > /etc/hosts
  rm -f /tmp/mlcg-hosts.$$
fi
exit 0
