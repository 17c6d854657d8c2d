#!/usr/bin/env bash
# Bad input to `strata build`: a clear error naming the file, a non-zero exit, no output left behind.
source "$(dirname "$0")/common.sh"
out=$WORK/out.hlod

no_output() {
    checks=$((checks + 1))
    if ls "$WORK" | grep -q '^out.hlod'; then fail "$1: left $(ls "$WORK" | grep '^out.hlod')"; fi
}

expect_failure "missing file" "missing.ply" "$STRATA" build "$WORK/missing.ply" -o "$out"; no_output "missing file"

: >"$WORK/empty.ply"
expect_failure "empty file" "empty.ply" "$STRATA" build "$WORK/empty.ply" -o "$out"; no_output "empty file"

printf 'this is not a mesh\n' >"$WORK/notes.xyz"
expect_failure "unknown format" "notes.xyz" "$STRATA" build "$WORK/notes.xyz" -o "$out"; no_output "unknown format"

# A binary PLY whose data stops halfway through the vertices.
{
    printf 'ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n'
    printf 'element face 2\nproperty list uchar int vertex_indices\nend_header\n'
    head -c 20 /dev/zero
} >"$WORK/truncated.ply"
expect_failure "truncated binary PLY" "truncated.ply" "$STRATA" build "$WORK/truncated.ply" -o "$out"; no_output "truncated"

# A binary PLY that claims two billion vertices in a few bytes.
{
    printf 'ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty float x\nproperty float y\nproperty float z\n'
    printf 'element face 1\nproperty list uchar int vertex_indices\nend_header\n'
    head -c 64 /dev/zero
} >"$WORK/huge.ply"
expect_failure "lying binary count" "huge.ply" "$STRATA" build "$WORK/huge.ply" -o "$out"; no_output "lying binary count"

printf 'OFF\n10 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' >"$WORK/lying.off"
expect_failure "counts that lie" "lying.off" "$STRATA" build "$WORK/lying.off" -o "$out"; no_output "counts that lie"

printf 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n' >"$WORK/past.off"
expect_failure "index past the vertices" "past.off" "$STRATA" build "$WORK/past.off" -o "$out"; no_output "index past"

printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\nnan 1 0\n0 1 0\n3 0 1 2\n' >"$WORK/nan.ply"
expect_failure "NaN coordinate" "nan.ply" "$STRATA" build "$WORK/nan.ply" -o "$out"; no_output "NaN"

printf 'OFF\n3 1 0\n0 0 0\n0 0 0\n0 0 0\n3 0 1 2\n' >"$WORK/point.off"
expect_failure "all at one point" "point.off" "$STRATA" build "$WORK/point.off" -o "$out"; no_output "one point"

write_octahedron "$WORK/octahedron.off"
: >"$WORK/plainfile"
expect_failure "unwritable output" "plainfile/out.hlod" "$STRATA" build "$WORK/octahedron.off" -o "$WORK/plainfile/out.hlod"
checks=$((checks + 1))
[ -z "$(ls -A "$WORK" | grep -v -e octahedron.off -e plainfile -e '\.ply$' -e '\.off$' -e '\.xyz$' -e '\.txt$')" ] ||
    fail "unwritable output: left $(ls "$WORK")"

expect_failure "levels too fine for the edges" "use fewer --levels" "$STRATA" build "$WORK/octahedron.off" -o "$out" --levels 3; no_output "levels too fine"
# Tiles and lists: every error names the file, and nothing is written.
expect_failure "missing tile" "missing_tile.off" "$STRATA" build "$WORK/octahedron.off" "$WORK/missing_tile.off" -o "$out"; no_output "missing tile"
printf 'octahedron.off\nabsent.off\n' >"$WORK/names_missing.txt"
expect_failure "list naming a missing file" "absent.off" "$STRATA" build @"$WORK/names_missing.txt" -o "$out"; no_output "list naming a missing file"
printf '# nothing here\n\n' >"$WORK/empty_list.txt"
expect_failure "empty list" "empty_list.txt: the list names no input files" "$STRATA" build @"$WORK/empty_list.txt" -o "$out"; no_output "empty list"
expect_failure "missing list" "no_list.txt: cannot read the list of inputs" "$STRATA" build @"$WORK/no_list.txt" -o "$out"; no_output "missing list"
expect_failure "bad tile" "past.off: line" "$STRATA" build "$WORK/octahedron.off" "$WORK/past.off" -o "$out"; no_output "bad tile"

# A file read whole into memory (all but binary PLY) is refused at once when it will not fit under --memory.
write_grid 450 "$WORK/big_grid.off"
expect_failure "memory ceiling" "needs about .* in memory for 405000 triangles read whole into memory, more than --memory 16M (16.0 MiB); binary PLY streams from disk" \
    "$STRATA" build "$WORK/big_grid.off" -o "$out" --memory 16M; no_output "memory ceiling"
write_grid 300 "$WORK/grid.off"
expect_usage "bad memory size" "'lots' is not a size in bytes" "$STRATA" build "$WORK/octahedron.off" -o "$out" --memory lots; no_output "bad memory size"
expect_usage "bad option value" "levels" "$STRATA" build "$WORK/octahedron.off" -o "$out" --levels many
expect_usage "bad block size" "block" "$STRATA" build "$WORK/octahedron.off" -o "$out" --block 6
expect_usage "no arguments" "input" "$STRATA" build

# A disk that fills up: files this process writes may not pass 1 MiB (ulimit -f; SIGXFSZ ignored, so a
# write past it fails with EFBIG as on a full disk). Level L's cubes of a 180 000-triangle grid need more.
mkdir "$WORK/full"
expect_failure "temporary disk full" "$WORK/full/grid.hlod.build: cannot write the build's temporary file " \
    bash -c 'trap "" XFSZ; ulimit -f 1024; exec "$@"' - "$STRATA" build "$WORK/grid.off" -o "$WORK/full/grid.hlod" -q
checks=$((checks + 1))
[ -z "$(ls "$WORK/full")" ] || fail "a build stopped by a full disk left $(ls "$WORK/full")"
finish
