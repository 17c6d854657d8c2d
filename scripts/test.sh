#!/usr/bin/env bash
# Set-up, configure, build and run the whole test suite with ctest.
# STRATA_SANITIZE=1 scripts/test.sh runs it under AddressSanitizer + UndefinedBehaviorSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
dir=$(scripts/build.sh)
jobs=$(nproc)
ctest --test-dir "$dir" --output-on-failure -j "$jobs"
