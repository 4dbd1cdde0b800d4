#!/bin/sh
# Makes N "hosts" on this machine for the netns test: network namespaces
# mlcg-h1..mlcg-hN, each with a veth pair to the bridge mlcg-br0 (10.77.0.254 on
# the root side) and the address 10.77.0.K, and /etc/hosts lines naming them
# (marked "# mlcg-netns"). Needs root and iproute2. Undo with teardown_hosts.sh.
# Usage: setup_hosts.sh [N=3]
set -eu
n="${1:-3}"
[ "$(id -u)" = 0 ] || { echo "setup_hosts.sh: needs root (ip netns)" >&2; exit 77; }
command -v ip >/dev/null || { echo "setup_hosts.sh: ip (iproute2) is not installed" >&2; exit 77; }
here="$(cd "$(dirname "$0")" && pwd)"
"$here/teardown_hosts.sh" >/dev/null 2>&1 || true
# A failure or an interrupt half-way leaves nothing behind.
trap '"$here/teardown_hosts.sh"' EXIT
trap 'exit 130' INT TERM
ip link add mlcg-br0 type bridge
ip addr add 10.77.0.254/24 dev mlcg-br0
ip link set mlcg-br0 up
k=1
while [ "$k" -le "$n" ]; do
  h="mlcg-h$k"
  ip netns add "$h"
  ip link add "mlcg-v$k" type veth peer name eth0 netns "$h"
  ip link set "mlcg-v$k" master mlcg-br0 up
  ip -n "$h" addr add "10.77.0.$k/24" dev eth0
  ip -n "$h" link set eth0 up
  ip -n "$h" link set lo up
  ip -n "$h" route add default via 10.77.0.254
  echo "10.77.0.$k $h # mlcg-netns" >> /etc/hosts
  k=$((k + 1))
done
echo "10.77.0.254 mlcg-h0 # mlcg-netns" >> /etc/hosts
trap - EXIT INT TERM
