#!/usr/bin/env bash
# Damaged and old .hlod files: `strata info` (which reads the header, the section table, MODL and NODE,
# never a payload) and `strata verify` (which reads everything) report what they read, name the file and
# exit 1; a version 1 model is refused with how to rebuild it.
source "$(dirname "$0")/common.sh"
SOURCE_DIR=$2
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

# section_offset FILE TAG: where section TAG starts (FORMAT.md §3: 32-byte entries from byte 32, the
# offset 8 bytes into an entry).
section_offset() {
    local count e
    count=$(od -An -tu4 -j12 -N4 "$1" | tr -d ' ')
    for ((e = 0; e < count; e++)); do
        if [ "$(dd if="$1" bs=1 skip=$((32 + 32 * e)) count=4 status=none)" = "$2" ]; then
            od -An -tu8 -j$((40 + 32 * e)) -N8 "$1" | tr -d ' '
            return
        fi
    done
}

payloads=$(section_offset "$WORK/good.hlod" PAYL)
[ "$((payloads % 4096))" -eq 0 ] || fail "the payloads start at $payloads, not on a 4 KiB boundary"
cp "$WORK/good.hlod" "$WORK/payload.hlod"
flip "$WORK/payload.hlod" $((payloads + 20))
expect_success "info: flipped payload byte (no payload is read)" "$STRATA" info "$WORK/payload.hlod"
expect_failure "verify: flipped payload byte" "checksum mismatch" "$STRATA" verify "$WORK/payload.hlod"

cp "$WORK/good.hlod" "$WORK/header.hlod"
flip "$WORK/header.hlod" 20
expect_failure "info: flipped header byte" "header.hlod: header checksum mismatch" "$STRATA" info "$WORK/header.hlod"
expect_failure "verify: flipped header byte" "header.hlod: header checksum mismatch" "$STRATA" verify "$WORK/header.hlod"

cp "$WORK/good.hlod" "$WORK/table.hlod"
flip "$WORK/table.hlod" $(($(section_offset "$WORK/good.hlod" NODE) + 3))
expect_failure "info: flipped node-table byte" "table.hlod: section 'NODE' checksum mismatch" "$STRATA" info "$WORK/table.hlod"
expect_failure "verify: flipped node-table byte" "table.hlod: section 'NODE' checksum mismatch" "$STRATA" verify "$WORK/table.hlod"

size=$(stat -c %s "$WORK/good.hlod")
head -c $((size / 2)) "$WORK/good.hlod" >"$WORK/short.hlod"
expect_failure "truncated .hlod" "short.hlod: truncated" "$STRATA" verify "$WORK/short.hlod"
printf 'not an hlod at all, just some text that is long enough to pass the size check for a header..........................................' >"$WORK/text.hlod"
expect_failure "not a .hlod" "not a .hlod" "$STRATA" info "$WORK/text.hlod"
expect_failure "missing .hlod" "nothere.hlod" "$STRATA" info "$WORK/nothere.hlod"

cp "$SOURCE_DIR/tests/data/octahedron_v1.hlod" "$WORK/old.hlod"
rebuild="$WORK/old.hlod: a version 1 model (from an older Strata); rebuild it from its scan: strata build SCAN -o $WORK/old.hlod"
expect_failure "info: a version 1 model" "$rebuild" "$STRATA" info "$WORK/old.hlod"
expect_failure "verify: a version 1 model" "$rebuild" "$STRATA" verify "$WORK/old.hlod"
finish
