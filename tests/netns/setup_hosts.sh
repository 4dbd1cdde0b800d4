#!/bin/sh
# Makes N "hosts" on this machine for the netns test: network namespaces
# mlcg-h1..mlcg-hN, each with a veth pair to the bridge mlcg-br0 (10.77.0.254 on
# the root side) and the address 10.77.0.K, and /etc/hosts lines naming them
# (marked "# mlcg-netns"). Needs root and iproute2. Undo with teardown_hosts.sh.
# TAG and NET give another set beside it (the Slurm test: mlcs- 10.78.0 makes
# mlcs-h1..N on the bridge mlcs-br0, 10.78.0.K, lines marked "# mlcs-netns").
# Usage: setup_hosts.sh [N=3] [TAG=mlcg-] [NET=10.77.0]
set -eu
n="${1:-3}"
tag="${2:-mlcg-}"
net="${3:-10.77.0}"
[ "$(id -u)" = 0 ] || { echo "setup_hosts.sh: needs root (ip netns)" >&2; exit 77; }
command -v ip >/dev/null || { echo "setup_hosts.sh: ip (iproute2) is not installed" >&2; exit 77; }
here="$(cd "$(dirname "$0")" && pwd)"
"$here/teardown_hosts.sh" "$tag" >/dev/null 2>&1 || true
# A failure or an interrupt half-way leaves nothing behind.
trap '"$here/teardown_hosts.sh" "$tag"' EXIT
trap 'exit 130' INT TERM
ip link add "${tag}br0" type bridge
ip addr add "$net.254/24" dev "${tag}br0"
ip link set "${tag}br0" up
k=1
while [ "$k" -le "$n" ]; do
  h="${tag}h$k"
  ip netns add "$h"
  ip link add "${tag}v$k" type veth peer name eth0 netns "$h"
  ip link set "${tag}v$k" master "${tag}br0" up
  ip -n "$h" addr add "$net.$k/24" dev eth0
  ip -n "$h" link set eth0 up
  ip -n "$h" link set lo up
  ip -n "$h" route add default via "$net.254"
  echo "$net.$k $h # ${tag}netns" >> /etc/hosts
  k=$((k + 1))
done
echo "$net.254 ${tag}h0 # ${tag}netns" >> /etc/hosts
trap - EXIT INT TERM
