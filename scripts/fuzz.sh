#!/bin/sh
# Fuzzes MLCG's readers of hostile input with libFuzzer (clang, ASan + UBSan): builds the targets of
# tests/fuzz into build-fuzz/, makes their seed corpora from the shipped cases, then runs each target
# for SECONDS, one after the other, niced. Prints per target the executions, executions per second,
# crashes (crash, leak, timeout or out-of-memory inputs, kept in build-fuzz/fuzz/TARGET/artifacts/)
# and corpus size; exits 1 if any target crashed. Corpora grow across runs in build-fuzz/fuzz/TARGET/corpus.
set -eu
cd "$(dirname "$0")/.."

ALL="case study hostfile stl bus_level bus_coupler manifest coupler_checkpoint level_checkpoint initial"
usage() {
  cat >&2 <<USAGE
usage: scripts/fuzz.sh [SECONDS] [TARGET...]
  SECONDS  run time per target (default 600)
  TARGET   one or more of: $ALL (default: all)
USAGE
  exit 2
}

seconds=600
if [ $# -gt 0 ]; then
  case "$1" in
    -h|--help) usage ;;
    *[!0-9]*|'') ;;
    *) seconds=$1; shift ;;
  esac
fi
[ "$seconds" -ge 1 ] 2>/dev/null || usage
targets=${*:-$ALL}
for t in $targets; do
  case " $ALL " in *" $t "*) ;; *) echo "fuzz.sh: unknown target '$t'" >&2; usage ;; esac
done
if ! command -v clang++ >/dev/null || ! command -v clang >/dev/null; then
  echo "fuzz.sh: clang is missing; scripts/setup.sh installs it (packages clang libclang-rt-14-dev)" >&2
  exit 2
fi

B=build-fuzz
F=$B/fuzz
nice -n 10 cmake -S . -B $B -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g" \
  -DMLCG_FUZZ=ON -DMLCG_BUILD_TESTS=OFF -DMLCG_BUILD_BENCH=OFF >/dev/null
nice -n 10 cmake --build $B -j2 --target fuzz_all

# Seeds: shipped cases, study files and meshes, and what the real writers make (fuzz_seeds).
rm -rf $F/seeds
mkdir -p $F/seeds/case $F/seeds/study $F/seeds/stl
copy_seeds() {  # DIR PATTERN...: every shipped file matching, named by its path
  dir=$1; shift
  for pattern in "$@"; do
    find cases tests/data -name "$pattern" | while read -r f; do
      cp "$f" "$F/seeds/$dir/$(echo "$f" | tr / _)"
    done
  done
}
copy_seeds case "*.toml"
rm -f $F/seeds/case/*study.toml
copy_seeds study "study.toml"
copy_seeds stl "*.stl"
nice -n 10 $B/bin/fuzz_seeds $F/seeds

# A smaller quarantine and shorter allocation stacks: about a third less time per input, on a shared machine.
# An allocation that cannot be served fails as it does without ASan: malloc returns null (HDF5 turns that
# into an error for a corrupt file's absurd sizes), new throws std::bad_alloc (a crash if MLCG lets it out).
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:quarantine_size_mb=16:malloc_context_size=8:allocator_may_return_null=1}"
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$(pwd)/scripts/lsan.supp}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1}"
date=$(date +%Y-%m-%d)
table="| target | executions | exec/s | crashes | corpus | date |
| --- | ---: | ---: | ---: | ---: | --- |"
failed=0
for t in $targets; do
  dir=$F/$t
  rm -rf "$dir/artifacts"
  mkdir -p "$dir/corpus" "$dir/artifacts" "$F/seeds/$t"
  echo "fuzz.sh: fuzz_$t for $seconds s (log: $dir/log.txt)"
  # One worker: the machine is shared. -timeout: one input may take 20 s at most (a hang is a crash).
  start=$(date +%s)
  nice -n 10 $B/bin/fuzz_$t -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=20 -print_final_stats=1 \
    -artifact_prefix="$dir/artifacts/" "$dir/corpus" "$F/seeds/$t" >"$dir/log.txt" 2>&1 || true
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$dir/log.txt" | tail -n 1)
  [ -n "$runs" ] || runs=$(sed -n 's/^#\([0-9]*\).*/\1/p' "$dir/log.txt" | tail -n 1)
  runs=${runs:-0}
  crashes=$(find "$dir/artifacts" -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' \) | wc -l)
  corpus=$(find "$dir/corpus" -type f | wc -l)
  elapsed=$(( $(date +%s) - start ))
  rate=$(( runs / (elapsed > 0 ? elapsed : 1) ))
  [ "$crashes" -eq 0 ] || { failed=1; echo "fuzz.sh: fuzz_$t crashed: $(ls "$dir/artifacts")" >&2; }
  table="$table
| $t | $runs | $rate | $crashes | $corpus | $date |"
done
echo "$table" | tee $F/results.md
exit $failed
