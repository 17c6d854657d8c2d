#!/usr/bin/env bash
# Set-up, configure, build and run the whole test suite with ctest.
# STRATA_SANITIZE=1 scripts/test.sh runs it under AddressSanitizer + UndefinedBehaviorSanitizer.
# STRATA_FUZZ_SECONDS=N scripts/test.sh then fuzzes every reader for N seconds each (scripts/fuzz.sh);
# STRATA_FUZZ_RUNS=N fuzzes N inputs each from a fixed seed instead (about the same inputs every run).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
dir=$(scripts/build.sh)
jobs=$(nproc)
ctest --test-dir "$dir" --output-on-failure -j "$jobs"
if [ "${STRATA_FUZZ_RUNS:-0}" != 0 ]; then scripts/fuzz.sh --runs "$STRATA_FUZZ_RUNS"
elif [ "${STRATA_FUZZ_SECONDS:-0}" != 0 ]; then scripts/fuzz.sh "$STRATA_FUZZ_SECONDS"; fi
