// Synthetic meshes for tests: a closed icosphere (watertight), an open grid with colours and UVs,
// and a temporary directory that cleans itself up.
#pragma once

#include "preprocess/mesh.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <unistd.h>
#include <utility>
#include <vector>

namespace strata::test {

// Icosahedron subdivided `levels` times, projected on the unit sphere, radius scaled and displaced
// a little per vertex (deterministic) so the quadrics are not all tied.
inline Mesh icosphere(int levels, float radius = 1.0f, float bumps = 0.02f) {
    const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
    Mesh m;
    m.positions = {-1, t, 0, 1, t, 0, -1, -t, 0, 1, -t, 0, 0, -1, t, 0, 1, t,
                   0, -1, -t, 0, 1, -t, t, 0, -1, t, 0, 1, -t, 0, -1, -t, 0, 1};
    m.indices = {0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6, 7, 1, 8,
                 3, 9, 4, 3, 4, 2, 3, 2, 6, 3, 6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1};
    for (int l = 0; l < levels; ++l) {
        std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoint;
        auto mid = [&](uint32_t a, uint32_t b) {
            auto key = std::minmax(a, b);
            auto it = midpoint.find(key);
            if (it != midpoint.end()) return it->second;
            uint32_t v = uint32_t(m.positions.size() / 3);
            for (int k = 0; k < 3; ++k) m.positions.push_back(0.5f * (m.positions[3 * a + k] + m.positions[3 * b + k]));
            midpoint[key] = v;
            return v;
        };
        std::vector<uint32_t> next;
        for (size_t i = 0; i < m.indices.size(); i += 3) {
            uint32_t a = m.indices[i], b = m.indices[i + 1], c = m.indices[i + 2];
            uint32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
            next.insert(next.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
        }
        m.indices = std::move(next);
    }
    std::mt19937 rng(12345);
    std::uniform_real_distribution<float> noise(-bumps, bumps);
    for (size_t v = 0; v < m.vertex_count(); ++v) {
        float* p = &m.positions[3 * v];
        float len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        float r = radius * (1.0f + noise(rng)) / len;
        for (int k = 0; k < 3; ++k) p[k] *= r;
    }
    return m;
}

// An open, gently curved n×n grid of quads with per-vertex colours and UVs.
inline Mesh colored_grid(int n) {
    Mesh m;
    for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) {
            float u = float(x) / n, v = float(y) / n;
            m.positions.insert(m.positions.end(), {u, v, 0.1f * std::sin(6 * u) * std::cos(5 * v)});
            m.colors.insert(m.colors.end(), {uint8_t(255 * u), uint8_t(255 * v), 128, 255});
            m.uvs.insert(m.uvs.end(), {u, v});
        }
    auto at = [n](int x, int y) { return uint32_t(y * (n + 1) + x); };
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            m.indices.insert(m.indices.end(), {at(x, y), at(x + 1, y), at(x + 1, y + 1), at(x, y), at(x + 1, y + 1), at(x, y + 1)});
    return m;
}

// An n×n grid cut by a UV seam down column `seam`: the column's vertices exist twice (left chart u,
// right chart u + 1), and every vertex carries a scanned normal.
inline Mesh seamed_grid(int n, int seam) {
    Mesh m;
    auto add = [&](int x, int y, float chart) {
        float u = float(x) / n, v = float(y) / n;
        float z = 0.1f * std::sin(6 * u) * std::cos(5 * v);
        m.positions.insert(m.positions.end(), {u, v, z});
        m.normals.insert(m.normals.end(), {0.0f, 0.0f, 1.0f});
        m.uvs.insert(m.uvs.end(), {u + chart, v});
        return uint32_t(m.positions.size() / 3 - 1);
    };
    std::vector<uint32_t> left((n + 1) * (n + 1)), right((n + 1) * (n + 1));
    for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) {
            uint32_t id = add(x, y, x > seam ? 1.0f : 0.0f);
            left[y * (n + 1) + x] = right[y * (n + 1) + x] = id;
            if (x == seam) right[y * (n + 1) + x] = add(x, y, 1.0f);
        }
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const auto& ids = x < seam ? left : right;
            auto at = [&](int i, int j) { return ids[j * (n + 1) + i]; };
            m.indices.insert(m.indices.end(), {at(x, y), at(x + 1, y), at(x + 1, y + 1), at(x, y), at(x + 1, y + 1), at(x, y + 1)});
        }
    return m;
}

// A file's bytes; none when it cannot be read.
inline std::vector<uint8_t> file_bytes(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), {}};
}

// What a shell command prints on its standard output (a tool the tests check against: exrheader,
// gdalinfo); empty when it cannot run.
inline std::string run_and_capture(const std::string& command) {
    std::unique_ptr<FILE, int (*)(FILE*)> pipe(::popen(command.c_str(), "r"), ::pclose);
    std::string output;
    char buffer[4096];
    while (pipe && std::fgets(buffer, sizeof buffer, pipe.get())) output += buffer;
    return output;
}

class TempDir {
public:
    // A new, empty folder every time (mkdtemp): a name made from the pid could meet the leftovers of
    // an earlier test process that had the same pid and was killed before it cleaned up.
    TempDir() {
        std::string name = (std::filesystem::temp_directory_path() / "strata-test-XXXXXX").string();
        if (!::mkdtemp(name.data())) throw std::runtime_error("cannot create a temporary folder for the test");
        path_ = name;
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    std::filesystem::path operator/(const std::string& name) const { return path_ / name; }
    const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
};

}  // namespace strata::test
