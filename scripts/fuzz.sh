#!/usr/bin/env bash
# Builds the fuzz targets (tests/fuzz/) with clang++ and libFuzzer + ASan + UBSan into build-fuzz/, then
# runs each for SECONDS (default 60), one after another, on one core each.
#   scripts/fuzz.sh [SECONDS] [TARGET...]      fuzz (all targets unless named)
#   scripts/fuzz.sh --runs N [TARGET...]       fuzz N inputs per target from a fixed seed and a fixed
#                                              count, not a time: nearly the same inputs on every run
#                                              (CI); coverage that depends on addresses may steer a few
#                                              mutations differently
#   scripts/fuzz.sh --merge [TARGET...]        minimize tests/fuzz/corpus/<target>/ with what was found
#                                              (the fewest inputs that reach every edge)
# Prints per target: executions, exec/s, CPU seconds, new inputs, failures. Exits non-zero if any target
# crashed, timed out (-timeout=1 per input), ran out of memory (-rss_limit_mb=2048) or leaked: the
# failing input is left in build-fuzz/crashers/<target>/ (replay it: build-fuzz/fuzz_<target> FILE).
# What the fuzzer found is kept in build-fuzz/corpus/<target>/ and used again by the next run.
set -euo pipefail
cd "$(dirname "$0")/.."

all_targets=(ply ply_stream obj off stl hlod path_json osg_path)
merge=0 budget=(-max_total_time=60)
if [ "${1:-}" = --merge ]; then merge=1; shift
elif [ "${1:-}" = --runs ] && [[ "${2:-}" =~ ^[0-9]+$ ]]; then budget=(-runs="$2" -seed=1); shift 2
elif [[ "${1:-}" =~ ^[0-9]+$ ]]; then budget=(-max_total_time="$1"); shift; fi
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=("${all_targets[@]}")

dir=build-fuzz
cmake -S tests/fuzz -B "$dir" -G Ninja -DCMAKE_CXX_COMPILER=clang++ >/dev/null
cmake --build "$dir" --target "${targets[@]/#/fuzz_}" >&2

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}

if [ $merge = 1 ]; then
  for t in "${targets[@]}"; do
    seeds=tests/fuzz/corpus/$t merged=$dir/merged/$t
    rm -rf "$merged" && mkdir -p "$merged" "$dir/corpus/$t"
    "$dir/fuzz_$t" -merge=1 -use_counters=0 -rss_limit_mb=2048 -timeout=1 "$merged" "$seeds" "$dir/corpus/$t" >"$dir/merge-$t.log" 2>&1 \
      || { echo "$t: merge failed, see $dir/merge-$t.log" >&2; exit 1; }
    rm -rf "$seeds" && mv "$merged" "$seeds"
    echo "$t: corpus now $(ls "$seeds" | wc -l) files, $(du -sh "$seeds" | cut -f1)"
  done
  exit 0
fi

failed=0
for t in "${targets[@]}"; do
  work=$dir/corpus/$t crashers=$dir/crashers/$t log=$dir/fuzz-$t.log
  mkdir -p "$work" "$crashers"
  dict=()
  [ -f "tests/fuzz/dict/$t.dict" ] && dict=(-dict="tests/fuzz/dict/$t.dict")
  corpora=("$work")  # new inputs go to the first; the committed corpus and regressions are only read
  for d in "tests/fuzz/corpus/$t" "tests/fuzz/regressions/$t"; do [ -d "$d" ] && corpora+=("$d"); done
  before=$(ls "$work" | wc -l)
  cpu_start=$(awk '{print $14 + $15 + $16 + $17}' /proc/$$/stat)
  status=0
  "$dir/fuzz_$t" "${budget[@]}" -rss_limit_mb=2048 -timeout=1 -print_final_stats=1 \
    -artifact_prefix="$crashers/" "${dict[@]}" "${corpora[@]}" \
    >"$log" 2>&1 || status=$?
  cpu_end=$(awk '{print $14 + $15 + $16 + $17}' /proc/$$/stat)
  ticks=$(getconf CLK_TCK)
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  printf '%-10s %12s runs %8s exec/s %7.1f s CPU %5d new inputs  %s\n' "$t" "${runs:-?}" "${rate:-?}" \
    "$(awk -v a="$cpu_start" -v b="$cpu_end" -v t="$ticks" 'BEGIN {print (b - a) / t}')" "$(( $(ls "$work" | wc -l) - before ))" \
    "$([ $status = 0 ] && echo "0 failures" || echo "FAILED (exit $status): $(grep -m1 -E '^==[0-9]+==ERROR|^SUMMARY|deadly signal|fuzz property' "$log" || true)")"
  if [ $status != 0 ]; then
    failed=1
    echo "  input: $(ls -t "$crashers" | head -1 | sed "s|^|$crashers/|")  log: $log" >&2
  fi
done
exit $failed
