// Mesh import and export: the first stage of preprocessing reads a scan from PLY, OBJ, OFF or STL into a
// welded, degenerate-free strata::Mesh; write_ply() writes one back out (tests, debugging, exports).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "preprocess/mesh.h"
#include "preprocess/progress.h"

namespace strata {

// Reads PLY (ascii and binary), OBJ (+ .mtl texture name), OFF or STL (ascii and binary), chosen by the
// file's content (magic/header), falling back to the extension. Returns the mesh welded (see weld()).
// Throws InputError naming the file and the problem for anything unreadable or malformed (a file that
// changes size while it is read included), and Cancelled when progress.cancel is raised. Reports
// progress as ("load", bytes read from disk, file size, "B"), then ("read", bytes parsed, size, "B").
Mesh read_mesh(const std::filesystem::path& path, const Progress& progress = {});

// The same, and appends to `warnings` what the file holds that was read past rather than refused (an
// unknown PLY header line, a binary STL whose triangle count disagrees with its size), one message
// each, starting with the file's name: for the caller to show, since preprocessing never prints.
Mesh read_mesh(const std::filesystem::path& path, const Progress& progress, std::vector<std::string>& warnings);

// Merges vertices equal in position and every attribute (+0.0 and -0.0 count as equal), drops triangles
// with two corners at the same position (degenerate, even when those corners are different seam copies),
// then drops vertices no triangle uses. Vertices at one position with different attributes stay apart
// (seams). Survivors keep their first-occurrence order, so the result is deterministic.
// Throws std::invalid_argument if the arrays disagree in size or an index is out of range.
void weld(Mesh& mesh);

enum class PlyEncoding { binary_little_endian, binary_big_endian, ascii };

// Writes PLY (float x y z, optional float nx ny nz, uchar red green blue alpha, float u v; faces as uchar
// count + uint indices) to a temporary file in the same directory, then renames it over `path`, so a
// reader never sees a half-written file. Throws std::runtime_error naming the file on failure (including
// an inconsistent mesh) and leaves nothing behind.
void write_ply(const std::filesystem::path& path, const Mesh& mesh,
               PlyEncoding encoding = PlyEncoding::binary_little_endian);

}  // namespace strata
