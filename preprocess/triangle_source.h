// What the builder reads a scan through (000 §3.3.2, the input as a stream of triangles): each source
// hands over its triangles in file order, in batches, with their corners' values (position and
// attributes) already looked up, so the builder never needs the whole mesh in memory. A binary PLY
// streams from disk (open_ply_stream, mesh_readers.h); anything else is read into a Mesh first.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "preprocess/mesh.h"
#include "preprocess/progress.h"

namespace strata {

// Which vertex attributes a source or a model has.
struct AttributeSet {
    bool normals = false, colors = false, uvs = false;
    bool operator==(const AttributeSet&) const = default;
};

// Consecutive triangles, three corners each, their values in struct-of-arrays form: positions are
// floats relative to the source's origin, −0 made +0 (as weld() does) so that equal corners have equal
// bytes. An attribute the source lacks is empty.
struct TriangleBatch {
    std::vector<float> positions;  // 9 per triangle
    std::vector<float> normals;    // 9 per triangle, or empty
    std::vector<uint8_t> colors;   // 12 per triangle, or empty
    std::vector<float> uvs;        // 6 per triangle, or empty

    size_t triangle_count() const { return positions.size() / 9; }
    // Whether two corners of triangle t share a position: weld() drops such triangles, and so does the
    // builder.
    bool degenerate(size_t t) const;
    void clear();
};

class TriangleSource {
public:
    virtual ~TriangleSource() = default;
    virtual const std::string& name() const = 0;  // the file as the user gave it
    virtual AttributeSet attributes() const = 0;
    virtual const std::string& texture() const = 0;
    virtual std::array<double, 3> origin() const = 0;
    virtual uint64_t vertex_count() const = 0;    // as the source holds them, before any weld
    virtual uint64_t triangle_count() const = 0;  // polygons fanned, degenerate ones included
    // Calls visit(batch) for all triangles in order, batch after batch; may be called again (a build
    // reads its input twice). Throws InputError naming the file for malformed data, and when the file
    // has changed since it was opened; Cancelled when progress.cancel is raised.
    virtual void for_each(const std::function<void(const TriangleBatch&)>& visit, const Progress& progress) = 0;
    // Bytes the source holds in memory (its mesh, or its cache).
    virtual uint64_t memory_bytes() const = 0;
};

// A mesh in memory as a source (Lua's strata.build of a mesh, tests, and input formats that cannot be
// streamed). The mesh must be consistent (indices in range).
std::unique_ptr<TriangleSource> mesh_source(Mesh mesh, std::string name);

// The sources of one model from its files: each binary PLY (with fixed-size vertex records) streams
// from disk, its vertex lookups through a cache of `cache_bytes`; the other files are read into memory
// together as read_tiles() reads them (joined, not welded: the builder welds). Every file's positions
// are taken against the first file's origin. Throws InputError naming the file that cannot be read;
// appends warnings as read_tiles() does.
std::vector<std::unique_ptr<TriangleSource>> open_sources(const std::vector<std::filesystem::path>& paths,
                                                          uint64_t cache_bytes, const Progress& progress,
                                                          std::vector<std::string>& warnings);

// The attributes every source has, with a warning for each one only some have (as read_tiles()), and
// the model's texture (the sources naming different ones is an InputError naming both).
struct ModelAttributes {
    AttributeSet kept;
    std::string texture;
};
ModelAttributes common_attributes(const std::vector<std::unique_ptr<TriangleSource>>& sources,
                                  std::vector<std::string>& warnings);

}  // namespace strata
