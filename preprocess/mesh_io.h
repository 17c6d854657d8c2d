// Mesh import and export: the first stage of preprocessing reads a scan from PLY, OBJ, OFF or STL into a
// welded, degenerate-free strata::Mesh; write_ply() writes one back out (tests, debugging, exports).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "preprocess/mesh.h"
#include "preprocess/progress.h"

namespace strata {

// Reads PLY (ascii and binary), OBJ (+ .mtl texture name), OFF or STL (ascii and binary), chosen by the
// file's content (magic/header), falling back to the extension. Returns the mesh welded (see weld()).
// Coordinates are read in double (a PLY 'double' as such, text with from_chars) and stored as floats
// relative to Mesh::origin, which each axis takes from the first vertex: its coordinate truncated
// toward zero to a multiple of 1024 (0 beyond 2^32). A mesh whose first vertex lies within 1024 units
// of zero on every axis therefore has origin 0 and reads exactly as a float reader reads it.
// Throws InputError naming the file and the problem for anything unreadable or malformed (a file that
// changes size while it is read included), and Cancelled when progress.cancel is raised. Reports
// progress as ("load", bytes read from disk, file size, "B"), then ("read", bytes parsed, size, "B").
Mesh read_mesh(const std::filesystem::path& path, const Progress& progress = {});

// The same, and appends to `warnings` what the file holds that was read past rather than refused (an
// unknown PLY header line, a binary STL whose triangle count disagrees with its size), one message
// each, starting with the file's name: for the caller to show, since preprocessing never prints.
Mesh read_mesh(const std::filesystem::path& path, const Progress& progress, std::vector<std::string>& warnings);

// Reads several files as one model: the tiles of a photogrammetry or survey export. Each is read as by
// read_mesh(), its positions against the first tile's origin (so a vertex two tiles repeat reads as the
// same float in both), then all are joined in the order given and welded: a vertex of one tile equal in
// position and every attribute to a vertex of another becomes one, so tiles that share their border
// vertices make one watertight surface. An attribute (normals, colours, UVs) that not every tile has
// is dropped, with a warning naming the tiles that lack it (UVs take the texture with them); tiles
// naming different textures are an InputError naming both. Every error names the tile; more than
// 2^32 vertices together (counted before the weld) is an InputError too. Progress is reported as by
// read_mesh(), in bytes of all the files together.
Mesh read_tiles(const std::vector<std::filesystem::path>& paths, const Progress& progress,
                std::vector<std::string>& warnings);

// How many triangles the file holds, for estimating a build's memory before reading it: the face count
// of a PLY or OFF header (polygons count as one), a binary STL's triangle count, else (OBJ, ASCII STL,
// a header it cannot read) a guess from the file's size. Reads only the first 64 KiB. Throws InputError
// naming the file when it cannot be opened or is not a regular file.
struct TriangleEstimate {
    uint64_t triangles = 0;
    bool from_header = false;  // false: guessed from the size
};
TriangleEstimate estimate_triangles(const std::filesystem::path& path);

// Merges vertices equal in position and every attribute (+0.0 and -0.0 count as equal), drops triangles
// with two corners at the same position (degenerate, even when those corners are different seam copies),
// then drops vertices no triangle uses. Vertices at one position with different attributes stay apart
// (seams). Survivors keep their first-occurrence order, so the result is deterministic.
// Throws std::invalid_argument if the arrays disagree in size or an index is out of range.
void weld(Mesh& mesh);

enum class PlyEncoding { binary_little_endian, binary_big_endian, ascii };

// Writes PLY (float x y z, or double x y z holding origin + position when the mesh's origin is not 0; optional float nx ny nz, uchar red green blue alpha, float u v; faces as uchar
// count + uint indices) to a temporary file in the same directory, then renames it over `path`, so a
// reader never sees a half-written file. Throws std::runtime_error naming the file on failure (including
// an inconsistent mesh) and leaves nothing behind.
void write_ply(const std::filesystem::path& path, const Mesh& mesh,
               PlyEncoding encoding = PlyEncoding::binary_little_endian);

}  // namespace strata
