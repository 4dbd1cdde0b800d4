#!/bin/sh
# Installs MLCG's dependencies from Debian 12 packages (only those missing)
# and builds Release into build/ (executables in build/bin/). Safe to re-run.
#
# ParaView 5.11 is installed for the paraview_check test (scripts/paraview_check.py through pvpython):
# paraview and python3-paraview (pvpython; only a recommendation of paraview, which
# --no-install-recommends leaves out), about 80 MB.
#
#   scripts/setup.sh --with-paraview   also installs xvfb + xauth for scripts/render_paraview.py
#       (Debian's ParaView renders only through an X server; xvfb-run provides one).
#   scripts/setup.sh --with-bench      also installs liggghts (Debian's LIGGGHTS 3.8.0), which
#       build/bin/mlcg_bench runs on the same scenes for its speed ratio (docs/performance.md);
#       without it the bench prints `liggghts=absent`. No test needs it.
set -e
cd "$(dirname "$0")/.."

with_paraview=""
with_bench=""
for arg in "$@"; do
  case "$arg" in
    --with-paraview) with_paraview=1 ;;
    --with-bench) with_bench=1 ;;
    *) echo "setup: unknown option '$arg' (allowed: --with-paraview, --with-bench)" >&2; exit 2 ;;
  esac
done

# clang and libclang-rt-14-dev: libFuzzer for scripts/fuzz.sh. iproute2: `ip netns`, the hosts of the
# multi-host test (minimal Debian images lack it). slurm-wlm and munge: the Slurm test starts its own
# munged, slurmctld and slurmd with a configuration, socket and ports of its own (tests/slurm).
PACKAGES="build-essential cmake libopenmpi-dev openmpi-bin libeigen3-dev libhdf5-dev hdf5-tools \
libprotobuf-dev protobuf-compiler libzmq3-dev cppzmq-dev libtomlplusplus-dev libcli11-dev \
libspdlog-dev libfmt-dev libgtest-dev libbenchmark-dev nlohmann-json3-dev python3-h5py python3-matplotlib \
clang libclang-rt-14-dev iproute2 slurm-wlm munge paraview python3-paraview"
[ -z "$with_paraview" ] || PACKAGES="$PACKAGES xvfb xauth"
[ -z "$with_bench" ] || PACKAGES="$PACKAGES liggghts"

missing=""
for p in $PACKAGES; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  echo "setup: installing$missing"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $missing
fi

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)"
