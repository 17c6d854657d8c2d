#!/usr/bin/env bash
# A .hlod with one flipped byte: `strata info` and `strata verify` both report it and exit non-zero.
source "$(dirname "$0")/common.sh"
write_octahedron "$WORK/octahedron.off"
expect_success "build" "$STRATA" build "$WORK/octahedron.off" -o "$WORK/good.hlod"
expect_success "info of a good file" "$STRATA" info "$WORK/good.hlod"
expect_success "verify of a good file" "$STRATA" verify "$WORK/good.hlod"

# flip FILE OFFSET: xor one byte with 0x5a.
flip() {
    local byte
    byte=$(od -An -tu1 -j "$2" -N1 "$1" | tr -d ' ')
    printf "$(printf '\\%03o' $((byte ^ 0x5a)))" | dd of="$1" bs=1 seek="$2" conv=notrunc status=none
}

cp "$WORK/good.hlod" "$WORK/payload.hlod"
flip "$WORK/payload.hlod" 140
expect_failure "info: flipped payload byte" "checksum mismatch" "$STRATA" info "$WORK/payload.hlod"
expect_failure "verify: flipped payload byte" "checksum mismatch" "$STRATA" verify "$WORK/payload.hlod"

cp "$WORK/good.hlod" "$WORK/header.hlod"
flip "$WORK/header.hlod" 30
expect_failure "info: flipped header byte" "header.hlod" "$STRATA" info "$WORK/header.hlod"
expect_failure "verify: flipped header byte" "header.hlod" "$STRATA" verify "$WORK/header.hlod"

size=$(stat -c %s "$WORK/good.hlod")
cp "$WORK/good.hlod" "$WORK/table.hlod"
flip "$WORK/table.hlod" $((size - 10))
expect_failure "verify: flipped node-table byte" "table.hlod" "$STRATA" verify "$WORK/table.hlod"

head -c $((size / 2)) "$WORK/good.hlod" >"$WORK/short.hlod"
expect_failure "truncated .hlod" "short.hlod" "$STRATA" verify "$WORK/short.hlod"
printf 'not an hlod at all, just some text that is long enough to pass the size check for a header..........................................' >"$WORK/text.hlod"
expect_failure "not a .hlod" "not a .hlod" "$STRATA" info "$WORK/text.hlod"
expect_failure "missing .hlod" "nothere.hlod" "$STRATA" info "$WORK/nothere.hlod"
finish
