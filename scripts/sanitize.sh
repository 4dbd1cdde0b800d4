#!/bin/sh
# Builds everything with AddressSanitizer + UndefinedBehaviorSanitizer (CMake preset `sanitize`, into
# build-san/) and runs the whole ctest suite in it. Extra arguments go to ctest (e.g. -R Launcher).
# Exit code 0 only when every test passed and no process wrote a sanitizer report.
#
# The tests start the real programs (mlcg, dem_level, coupler_service, some through mpirun); they all
# inherit the options below. A report from a child can hide behind a test that expects that child to
# fail, so every process writes its reports to build-san/sanitizer-reports/report.PID (a file appears
# only when there is something to report) and any such file fails this script.
# Leaks in Open MPI and HDF5's own libraries are suppressed by scripts/lsan.supp.
set -eu
cd "$(dirname "$0")/.."
root="$(pwd)"
jobs="${JOBS:-2}"

cmake --preset sanitize
cmake --build --preset sanitize -j "$jobs"

reports="$root/build-san/sanitizer-reports"
rm -rf "$reports"
mkdir -p "$reports"
# exitcode 86: a sanitizer finding, told apart from the programs' own exit codes in test output.
# fast_unwind_on_malloc=0: whole allocation stacks, so that a leak inside Open MPI (built without frame
# pointers) still shows the library frames its suppression matches.
export ASAN_OPTIONS="log_path=$reports/report:exitcode=86:halt_on_error=1:detect_leaks=1:check_initialization_order=1:strict_init_order=1:fast_unwind_on_malloc=0"
export UBSAN_OPTIONS="log_path=$reports/report:exitcode=86:halt_on_error=1:print_stacktrace=1"
export LSAN_OPTIONS="suppressions=$root/scripts/lsan.supp:print_suppressions=0"
# The tests' exit deadlines (e.g. "SIGTERM ends it within 2 s") grow by this factor: an instrumented
# process's exit alone (the leak check with full unwinding) takes seconds.
export MLCG_TEST_TIME_SCALE="${MLCG_TEST_TIME_SCALE:-10}"

start="$(date +%s)"
rc=0
ctest --test-dir build-san --output-on-failure -j "$jobs" "$@" || rc=$?
seconds=$(( $(date +%s) - start ))

found=0
for f in "$reports"/report.*; do
  [ -e "$f" ] || continue
  found=$((found + 1))
  echo "=== sanitizer report $f"
  cat "$f"
done
echo "sanitize: ctest exit $rc, $found sanitizer report(s), ${seconds} s ($(date -u +%Y-%m-%d))"
[ "$rc" -eq 0 ] && [ "$found" -eq 0 ]
