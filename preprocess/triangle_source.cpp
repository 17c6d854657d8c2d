#include "preprocess/triangle_source.h"

#include <cstring>

#include "preprocess/mesh_io.h"
#include "preprocess/mesh_readers.h"

namespace strata {
namespace {

constexpr size_t kBatchTriangles = 1 << 15;

class MeshSource final : public TriangleSource {
public:
    MeshSource(Mesh mesh, std::string name) : mesh_(std::move(mesh)), name_(std::move(name)) {}

    const std::string& name() const override { return name_; }
    AttributeSet attributes() const override { return {mesh_.has_normals(), mesh_.has_colors(), mesh_.has_uvs()}; }
    const std::string& texture() const override { return mesh_.texture; }
    std::array<double, 3> origin() const override { return mesh_.origin; }
    uint64_t vertex_count() const override { return mesh_.vertex_count(); }
    uint64_t triangle_count() const override { return mesh_.triangle_count(); }
    uint64_t memory_bytes() const override { return mesh_.memory_bytes(); }

    void for_each(const std::function<void(const TriangleBatch&)>& visit, const Progress& progress) override {
        TriangleBatch batch;
        const size_t triangles = mesh_.triangle_count();
        for (size_t first = 0; first < triangles; first += kBatchTriangles) {
            progress.check();
            batch.clear();
            const size_t last = std::min(triangles, first + kBatchTriangles);
            for (size_t corner = 3 * first; corner < 3 * last; ++corner) {
                const size_t v = mesh_.indices[corner];
                detail::append_canonical(batch.positions, &mesh_.positions[3 * v], 3);
                if (mesh_.has_normals()) detail::append_canonical(batch.normals, &mesh_.normals[3 * v], 3);
                if (mesh_.has_colors()) batch.colors.insert(batch.colors.end(), &mesh_.colors[4 * v], &mesh_.colors[4 * v] + 4);
                if (mesh_.has_uvs()) detail::append_canonical(batch.uvs, &mesh_.uvs[2 * v], 2);
            }
            visit(batch);
        }
    }

private:
    Mesh mesh_;
    std::string name_;
};

}  // namespace

bool TriangleBatch::degenerate(size_t t) const {
    const float* p = &positions[9 * t];
    auto same = [&](int a, int b) { return p[3 * a] == p[3 * b] && p[3 * a + 1] == p[3 * b + 1] && p[3 * a + 2] == p[3 * b + 2]; };
    return same(0, 1) || same(1, 2) || same(0, 2);
}

void TriangleBatch::clear() {
    positions.clear(), normals.clear(), colors.clear(), uvs.clear();
}

std::unique_ptr<TriangleSource> mesh_source(Mesh mesh, std::string name) {
    return std::make_unique<MeshSource>(std::move(mesh), std::move(name));
}

std::vector<std::unique_ptr<TriangleSource>> open_sources(const std::vector<std::filesystem::path>& paths,
                                                          uint64_t cache_bytes, const Progress& progress,
                                                          std::vector<std::string>& warnings) {
    std::vector<std::unique_ptr<TriangleSource>> sources;
    std::array<double, 3> first_origin{};
    for (size_t i = 0; i < paths.size(); ++i) {
        const std::array<double, 3>* origin = i == 0 ? nullptr : &first_origin;
        std::unique_ptr<TriangleSource> source =
            detail::open_ply_stream(paths[i], paths[i].string(), origin, cache_bytes, warnings);
        if (!source) source = mesh_source(detail::read_mesh_as_listed(paths[i], progress, warnings, origin), paths[i].string());
        if (i == 0) first_origin = source->origin();
        sources.push_back(std::move(source));
    }
    return sources;
}

ModelAttributes common_attributes(const std::vector<std::unique_ptr<TriangleSource>>& sources,
                                  std::vector<std::string>& warnings) {
    std::vector<detail::TileAttributes> tiles;
    for (const auto& source : sources) tiles.push_back({source->name(), source->attributes(), source->texture()});
    return detail::common_attributes(tiles, warnings);
}

}  // namespace strata
