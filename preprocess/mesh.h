// The in-memory triangle mesh that every stage of preprocessing passes along: flat arrays, one entry
// per vertex (wedge), so a vertex that carries two UVs or colours at one position is two vertices.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace strata {

struct Mesh {
    // A vertex's true position is origin + its float position, the sum taken in double: survey scans
    // in projected coordinates (UTM eastings of 6-7 digits in metres) keep their millimetres, which a
    // float holding the whole coordinate would round to a quarter metre. The readers pick it from
    // the data (read_mesh() says how); 0 for data near zero.
    std::array<double, 3> origin{};
    std::vector<float> positions;   // x y z per vertex, relative to origin
    std::vector<float> normals;     // nx ny nz per vertex, or empty
    std::vector<uint8_t> colors;    // r g b a per vertex, or empty
    std::vector<float> uvs;         // u v per vertex, or empty
    std::vector<uint32_t> indices;  // three per triangle, counter-clockwise
    std::string texture;            // texture image named by the source (OBJ map_Kd), or empty

    size_t vertex_count() const { return positions.size() / 3; }
    size_t triangle_count() const { return indices.size() / 3; }
    bool has_normals() const { return !normals.empty(); }
    bool has_colors() const { return !colors.empty(); }
    bool has_uvs() const { return !uvs.empty(); }
    // Bytes the mesh holds in memory (what the benchmark's peak-memory ratio is measured against).
    size_t memory_bytes() const {
        return positions.size() * 4 + normals.size() * 4 + colors.size() + uvs.size() * 4 + indices.size() * 4;
    }
};

// Bad input: the message names the file and what is wrong with it ("bunny.ply: face 12 indexes vertex 99
// of 40"). Every reader and the builder report malformed data this way, never by crashing.
class InputError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

}  // namespace strata
