#!/usr/bin/env bash
# The bundled sample (a real scan, closed): builds, verifies with every level closed, describes itself,
# and builds byte-identically on one thread and on all.
source "$(dirname "$0")/common.sh"
sample=$2/data/bunny.off
[ -s "$sample" ] || { echo "sample missing: run scripts/setup.sh"; exit 1; }
expect_success "build" "$STRATA" build "$sample" -o "$WORK/bunny.hlod" --threads 0
expect_success "verify" "$STRATA" verify "$WORK/bunny.hlod"
checks=$((checks + 1)); grep -q "every level closed" "$WORK/out.txt" || fail "verify: the bunny's levels are not all closed"
expect_success "info" "$STRATA" info "$WORK/bunny.hlod"
checks=$((checks + 1)); grep -q "75408 triangles" "$WORK/out.txt" || fail "info: wrong input triangle count"
expect_success "build on one thread" "$STRATA" build "$sample" -o "$WORK/one.hlod" --threads 1 -q
checks=$((checks + 1)); cmp -s "$WORK/bunny.hlod" "$WORK/one.hlod" || fail "output depends on the thread count"
expect_success "help" "$STRATA" --help
expect_success "build help" "$STRATA" build --help
checks=$((checks + 1)); grep -q -- "--sigma0" "$WORK/out.txt" || fail "build --help lacks --sigma0"
finish
