#!/usr/bin/env bash
# strata build --resume after SIGKILL, and the cluster's way (--plan, --run-blocks under xargs -P 2,
# --assemble): both make the bytes of an uninterrupted build. (tests/unit/test_resume_build.cpp kills
# builds at chosen points of every stage; this checks the command line around them.)
source "$(dirname "$0")/common.sh"
# 2 M triangles: big enough to still be running its jobs when the kill comes.
write_grid 1000 "$WORK/grid.off"
expect_success "reference build" "$STRATA" build "$WORK/grid.off" -o "$WORK/ref.hlod" -q

# Killed once its plan is whole (the input read and spilled), while its jobs run.
kill_when "$WORK/grid.hlod.build/plan" "$STRATA" build "$WORK/grid.off" -o "$WORK/grid.hlod" -q
checks=$((checks + 1))
[ -f "$WORK/grid.hlod.build/plan" ] && [ ! -e "$WORK/grid.hlod" ] ||
    fail "the build was not killed between its plan and its output: $(ls "$WORK" "$WORK/grid.hlod.build" 2>&1)"

expect_failure "leftovers without --resume" "add --resume to go on" "$STRATA" build "$WORK/grid.off" -o "$WORK/grid.hlod" -q
expect_failure "resume with another ratio" "it was begun with --ratio 0.25 (now 0.3)" \
    "$STRATA" build "$WORK/grid.off" -o "$WORK/grid.hlod" -q --resume --ratio 0.3
checks=$((checks + 1))
[ -f "$WORK/grid.hlod.build/plan" ] || fail "a refused resume removed the work folder"
# Other threads and memory change nothing.
expect_success "resume" "$STRATA" build "$WORK/grid.off" -o "$WORK/grid.hlod" --resume --threads 1 --memory 512M
checks=$((checks + 1))
grep -q "resumed, [0-9]* of its [0-9]* jobs had finished" "$WORK/out.txt" || fail "resume does not say so: $(cat "$WORK/out.txt")"
checks=$((checks + 1))
cmp -s "$WORK/grid.hlod" "$WORK/ref.hlod" || fail "the resumed build differs from the uninterrupted one"
checks=$((checks + 1))
[ ! -e "$WORK/grid.hlod.build" ] || fail "the resumed build left its work folder"
expect_success "resume a complete output" "$STRATA" build "$WORK/grid.off" -o "$WORK/grid.hlod" --resume
checks=$((checks + 1))
grep -q "complete; nothing to resume" "$WORK/out.txt" && cmp -s "$WORK/grid.hlod" "$WORK/ref.hlod" ||
    fail "--resume on a complete output: $(cat "$WORK/out.txt")"

# The cluster's way: a plan, then each stage's jobs in ranges of 8, two processes at a time, then the
# assembly (README "Building on a cluster").
plan="$WORK/plan"
expect_success "plan" "$STRATA" build "$WORK/grid.off" --plan "$plan" -q
checks=$((checks + 1))
[ -f "$plan/jobs.txt" ] || fail "--plan wrote no job list"
expect_failure "assemble before the jobs" "stage 0 (jobs 0-[0-9]*) has [0-9]* unfinished jobs" \
    "$STRATA" build --assemble "$plan" -o "$WORK/cluster.hlod"
last_of_stage1=$(awk '$1 == "stage" && $2 == 1 { print $5 }' "$plan/jobs.txt")
expect_failure "a stage before the one before" "need the stage before finished" \
    "$STRATA" build --run-blocks "$plan" "$last_of_stage1" -q
expect_usage "a range that is not one" "job range FIRST-LAST" "$STRATA" build --run-blocks "$plan" 3-x
expect_failure "a range past the plan" "in its plan, which has jobs 0-" "$STRATA" build --run-blocks "$plan" 0-99999999
expect_failure "a plan into a used folder" "already holds files" "$STRATA" build "$WORK/grid.off" --plan "$plan" -q
awk '$1 == "stage" { for (first = $4; first <= $5; first += 8) print first "-" (first + 7 > $5 ? $5 : first + 7), $2 }' \
    "$plan/jobs.txt" >"$WORK/ranges.txt"
checks=$((checks + 1))
for stage in $(awk '{ print $2 }' "$WORK/ranges.txt" | uniq); do
    awk -v s="$stage" '$2 == s { print $1 }' "$WORK/ranges.txt" |
        xargs -P 2 -I RANGE "$STRATA" build --run-blocks "$plan" RANGE -q || { fail "stage $stage's jobs failed"; break; }
done
expect_success "assemble" "$STRATA" build --assemble "$plan" -o "$WORK/cluster.hlod"
checks=$((checks + 1))
cmp -s "$WORK/cluster.hlod" "$WORK/ref.hlod" || fail "the cluster's build differs from the single machine's"
checks=$((checks + 1))
[ ! -e "$plan" ] || fail "--assemble left the plan's folder"
finish
