#!/usr/bin/env bash
# Runs every fuzz target listed in <build>/fuzz_targets.txt (written by test/fuzz/CMakeLists.txt) for a
# bounded time and prints, per target: executions, executions per second, coverage (edges and features),
# the corpus size and the findings (crash, leak, timeout and out-of-memory inputs). Exits 1 if any target
# found something or failed to run.
#
#   run_fuzzers.sh <fuzz dir> <seconds per target>
#
# <fuzz dir>/build holds the targets; each keeps its corpus in <fuzz dir>/corpus/<target> (kept between
# runs, never in the repository) and writes findings to <fuzz dir>/findings/<target>/.
set -euo pipefail

fuzz_dir=$1
seconds=$2
# One input that runs longer than this is a hang (a finding); generous because the machines that run
# this are shared and loaded.
readonly kInputTimeout_s=20

list=$fuzz_dir/build/fuzz_targets.txt
[ -s "$list" ] || { echo "run_fuzzers: no targets in $list (build test/fuzz first)" >&2; exit 1; }

rc=0
summary=()
while IFS='|' read -r name seeds dict; do
  [ -n "$name" ] || continue
  corpus=$fuzz_dir/corpus/$name
  findings=$fuzz_dir/findings/$name
  log=$fuzz_dir/logs/$name.log
  rm -rf "$findings"
  mkdir -p "$corpus" "$findings" "$(dirname "$log")"
  args=(-max_total_time="$seconds" -timeout="$kInputTimeout_s" -print_final_stats=1
        -artifact_prefix="$findings/")
  [ -n "$dict" ] && args+=(-dict="$dict")
  echo "==> fuzz: $name for $seconds s (log: $log)"
  # shellcheck disable=SC2086  # seeds is a space-separated list of folders
  "$fuzz_dir/build/$name" "${args[@]}" "$corpus" $seeds > "$log" 2>&1 || true
  executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  coverage=$(grep -oE 'cov: [0-9]+ ft: [0-9]+ corp: [0-9]+' "$log" | tail -1 || true)
  found=$(find "$findings" -type f | wc -l)
  summary+=("$(printf '%-20s %12s %10s   %-34s %s' "$name" "${executions:-?}" "${rate:-?}" "${coverage:-?}" "$found")")
  if [ "$found" != 0 ] || [ -z "$executions" ]; then
    rc=1
    echo "fuzz: $name: $found finding(s) in $findings; the log's end:"
    tail -40 "$log"
  fi
done < "$list"

echo "==> fuzz: $seconds s per target"
printf '%-20s %12s %10s   %-34s %s\n' target executions execs/s "coverage (edges, features, corpus)" findings
printf '%s\n' "${summary[@]}"
exit $rc
