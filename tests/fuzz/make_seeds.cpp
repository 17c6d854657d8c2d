// Writes small, valid seed inputs for every fuzz target into <dir>/<target>/ (usually tests/fuzz/corpus,
// then minimized with libFuzzer's -merge=1 by scripts/fuzz.sh --merge): meshes from the test suite's
// synthetic shapes in each format and variant the readers know, .hlod models built from them, and
// camera paths using every option. Usage: fuzz_make_seeds DIR
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

#include "engine/path/camera_path.h"
#include "engine/path/osg_path.h"
#include "preprocess/cube_textures.h"
#include "preprocess/embedding.h"
#include "preprocess/embedding_file.h"
#include "preprocess/georeference.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_format.h"
#include "preprocess/mesh_io.h"
#include "preprocess/terrain_build.h"
#include "preprocess/terrain_heights.h"
#include "tests/support/test_meshes.h"

#if STRATA_SEEDS_WITH_GDAL
#include <gdal_priv.h>
#endif

namespace {

using strata::Mesh;
namespace fs = std::filesystem;

void write_text(const fs::path& file, const std::string& text) {
    fs::create_directories(file.parent_path());
    std::ofstream(file, std::ios::binary) << text;
}

// OBJ with whatever attributes the mesh has, faces as v/vt/vn; `quads` pairs triangles into one
// polygon line where the grid made them so, to reach the reader's fan triangulation.
std::string obj_text(const Mesh& m, const std::string& mtl) {
    std::ostringstream out;
    out << "# seed\n";
    if (!mtl.empty()) out << "mtllib " << mtl << "\no grid\ng part\nusemtl stone\ns 1\n";
    for (size_t v = 0; v < m.vertex_count(); ++v) {
        out << "v " << m.positions[3 * v] << ' ' << m.positions[3 * v + 1] << ' ' << m.positions[3 * v + 2];
        if (m.has_colors())
            for (int c = 0; c < 3; ++c) out << ' ' << m.colors[4 * v + c] / 255.0;
        out << '\n';
        if (m.has_uvs()) out << "vt " << m.uvs[2 * v] << ' ' << m.uvs[2 * v + 1] << '\n';
        if (m.has_normals())
            out << "vn " << m.normals[3 * v] << ' ' << m.normals[3 * v + 1] << ' ' << m.normals[3 * v + 2] << '\n';
    }
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        out << 'f';
        for (int c = 0; c < 3; ++c) {
            const uint32_t i = m.indices[t + c] + 1;
            out << ' ' << i;
            if (m.has_uvs() || m.has_normals()) out << '/' << (m.has_uvs() ? std::to_string(i) : "");
            if (m.has_normals()) out << '/' << i;
        }
        out << '\n';
    }
    return out.str();
}

std::string off_text(const Mesh& m) {
    std::ostringstream out;
    out << (m.has_colors() ? "COFF" : "OFF") << "\n# seed\n" << m.vertex_count() << ' ' << m.triangle_count() << " 0\n";
    for (size_t v = 0; v < m.vertex_count(); ++v) {
        out << m.positions[3 * v] << ' ' << m.positions[3 * v + 1] << ' ' << m.positions[3 * v + 2];
        if (m.has_colors())
            for (int c = 0; c < 4; ++c) out << ' ' << int(m.colors[4 * v + c]);
        out << '\n';
    }
    for (size_t t = 0; t < m.indices.size(); t += 3)
        out << "3 " << m.indices[t] << ' ' << m.indices[t + 1] << ' ' << m.indices[t + 2] << '\n';
    out << "4 0 1 2 3\n";  // a quad: fan-triangulated
    return out.str();
}

std::string stl_ascii(const Mesh& m) {
    std::ostringstream out;
    out << "solid seed\n";
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        out << "  facet normal 0 0 1\n    outer loop\n";
        for (int c = 0; c < 3; ++c) {
            const float* p = &m.positions[3 * m.indices[t + c]];
            out << "      vertex " << p[0] << ' ' << p[1] << ' ' << p[2] << '\n';
        }
        out << "    endloop\n  endfacet\n";
    }
    return out.str() + "endsolid seed\n";
}

std::string stl_binary(const Mesh& m) {
    std::string out(80, ' ');
    out.replace(0, 11, "binary seed");
    auto put = [&out](const auto& value) { out.append(reinterpret_cast<const char*>(&value), sizeof(value)); };
    put(uint32_t(m.triangle_count()));
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        for (float n : {0.0f, 0.0f, 1.0f}) put(n);
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) put(m.positions[3 * m.indices[t + c] + k]);
        put(uint16_t(0));
    }
    return out;
}

void mesh_seeds(const fs::path& dir) {
    const Mesh sphere = strata::test::icosphere(0);
    const Mesh grid = strata::test::colored_grid(2);
    const Mesh seamed = strata::test::seamed_grid(2, 1);
    fs::create_directories(dir / "ply");
    strata::write_ply(dir / "ply/sphere_le.ply", sphere);
    strata::write_ply(dir / "ply/grid_ascii.ply", grid, strata::PlyEncoding::ascii);
    strata::write_ply(dir / "ply/grid_be.ply", grid, strata::PlyEncoding::binary_big_endian);
    strata::write_ply(dir / "ply/seamed_ascii.ply", seamed, strata::PlyEncoding::ascii);

    write_text(dir / "obj/sphere.obj", obj_text(sphere, ""));
    write_text(dir / "obj/seamed.obj", obj_text(seamed, ""));
    // fuzz_obj.cpp: the OBJ, a NUL, then its fuzz.mtl.
    write_text(dir / "obj/grid_mtl.obj", obj_text(grid, "fuzz.mtl") + '\0' +
                                          "newmtl stone\nKd 1 1 1\nmap_Kd -s 1 1 1 -clamp on stone.png\n");

    write_text(dir / "off/sphere.off", off_text(sphere));
    write_text(dir / "off/grid.off", off_text(grid));

    write_text(dir / "stl/sphere_ascii.stl", stl_ascii(sphere));
    write_text(dir / "stl/sphere_binary.stl", stl_binary(sphere));
}

// `from` again with a GEOR section (the mesh builder writes none), and with `terrain` a TERR section in
// that frame (required unless the frame is the CRS's plane), as a terrain build writes them.
void georeferenced_copy(const fs::path& from, const fs::path& to, std::optional<uint32_t> terrain_frame = {}) {
    strata::HlodFile file(from);
    strata::HlodHeader header = file.header();
    header.crs = "EPSG:32633";
    header.geo_origin[0] = 500000, header.geo_origin[1] = 5400000, header.geo_origin[2] = 300;
    if (terrain_frame)
        header.terrain = strata::TerrainGrid{.columns = 7, .rows = 5, .spacing = {30, 30}, .nodata_samples = 3, .cube_cells = 8,
                                             .rows_run_north = false,
                                             .frame = *terrain_frame,
                                             .raster_geographic = *terrain_frame != 0,
                                             .raster_crs = {},
                                             .first_sample = {500015, 5400135},
                                             .semi_major = 6378137,
                                             .inverse_flattening = 298.257223563};
    strata::HlodWriter writer(to);
    for (const strata::HlodNode& node : file.nodes()) writer.add_cube(node, file.read_payload(node));
    if (terrain_frame) {  // its heights (section HGHT), three of them nodata
        std::vector<float> heights(7 * 5);
        for (size_t s = 0; s < heights.size(); ++s) heights[s] = s % 11 == 4 ? NAN : 300.0f + 0.25f * float(s * s % 17);
        strata::HeightSectionWriter section(writer, 7, 5, {}, to.string());
        section.add_band(heights, 5, 1);
        section.finish();
        // And a texture per cube (section TXTR): 8 × 8 texels, a gradient.
        strata::TextureSectionWriter textures(writer, {.size = 8, .margin = 0.0625f});
        std::vector<uint8_t> rgb(8 * 8 * 3);
        for (size_t t = 0; t < rgb.size(); ++t) rgb[t] = uint8_t(t * 5);
        for (const strata::HlodNode& node : file.nodes()) textures.add(node.level, node.i, node.j, node.k, strata::encode_bc1_chain(rgb, 8));
        textures.finish();
    }
    writer.finish(header);
}

#if STRATA_SEEDS_WITH_GDAL
// A terrain built from a small DEM (payload codec 3, the grid payloads; TERR, HGHT): 23 × 17 samples,
// nodata in a block and a few pixels, cubes of 8 cells, heights on a lattice 8 steps coarse.
void terrain_seed(const fs::path& dem, const fs::path& out) {
    GDALAllRegister();
    constexpr int width = 23, height = 17;
    GDALDataset* data = GetGDALDriverManager()->GetDriverByName("GTiff")->Create(dem.c_str(), width, height, 1, GDT_Float32, nullptr);
    double transform[6] = {500000, 30, 0, 5400000, 0, -30};
    data->SetGeoTransform(transform);
    data->SetProjection("EPSG:32633");
    std::vector<float> heights(width * height);
    for (int s = 0; s < width * height; ++s) {
        const int c = s % width, r = s / width;
        heights[size_t(s)] = (c > 14 && r < 5) || s % 29 == 3 ? -9999.0f : float(300 + 40 * std::sin(c * 0.4) * std::cos(r * 0.3));
    }
    data->GetRasterBand(1)->SetNoDataValue(-9999);
    if (data->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, width, height, heights.data(), width, height, GDT_Float32, 0, 0) != CE_None)
        throw std::runtime_error("cannot write " + dem.string());
    GDALClose(data);
    strata::TerrainSettings settings;
    settings.cube_cells = 8;
    settings.threads = 1;
    settings.height_tolerance = 30.0 * 8 * 8 / 32768 * 4;  // a shift of 3
    strata::build_terrain({dem}, out, settings, "dem.tif");
    fs::remove(dem);
}

// Embedding files (section EMBD, FORMAT.md §4.10) on that terrain: a 20 m patch between its nodata samples
// (a skirt and a zone), and a closed site that stands (a model without cubes).
void embedding_seeds(const fs::path& terrain, const fs::path& dir) {
    strata::BuildSettings settings;
    settings.threads = 1;
    settings.lock_boundary = true;
    Mesh patch = strata::test::seamed_grid(4, 0);
    for (size_t v = 0; v < patch.vertex_count(); ++v)
        for (int a = 0; a < 2; ++a) patch.positions[3 * v + size_t(a)] *= 20.0f;
    strata::build_hlod(std::move(patch), dir / "patch.site", settings, "patch.obj");
    strata::build_hlod(strata::test::icosphere(1, 3.0f), dir / "statue.site", settings, "statue.ply");
    strata::EmbedSettings embed;
    embed.threads = 1;
    const strata::TerrainSite site = strata::TerrainSite::open(terrain);
    const std::array<double, 3> at = site.georeference->to_geo({300, 225, 0});  // column 10, row 8.5
    embed.placement.at = std::array<double, 2>{at[0], at[1]};
    strata::build_embedding(terrain, dir / "patch.site", dir / "embedding", embed);
    strata::build_embedding(terrain, dir / "statue.site", dir / "embedding_standing", embed);
    fs::remove(dir / "patch.site"), fs::remove(dir / "statue.site");
}
#endif

void hlod_seeds(const fs::path& dir) {
    fs::create_directories(dir / "hlod");
    strata::BuildSettings settings;
    settings.threads = 1;
    settings.leaf_triangles = 64;  // a few levels from a small mesh
    strata::build_hlod(strata::test::icosphere(2), dir / "hlod/sphere", settings, "sphere.ply");
    Mesh grid = strata::test::colored_grid(6);  // colours and UVs: payload streams 4 and 5
    grid.texture = "grid.png";
    strata::build_hlod(std::move(grid), dir / "hlod/grid", settings, "grid.obj");
    georeferenced_copy(dir / "hlod/sphere", dir / "hlod/sphere_georeferenced");
    georeferenced_copy(dir / "hlod/grid", dir / "hlod/grid_terrain", 0);
    georeferenced_copy(dir / "hlod/grid", dir / "hlod/grid_terrain_enu", 1);
#if STRATA_SEEDS_WITH_GDAL
    terrain_seed(dir / "hlod/dem.tif", dir / "hlod/terrain");
    embedding_seeds(dir / "hlod/terrain", dir / "hlod");
#endif
}

void path_seeds(const fs::path& dir) {
    using strata::Keyframe;
    std::vector<Keyframe> turning(3);
    turning[0].position = {0, 0, 5}, turning[0].orientation = glm::dquat(1, 0, 0, 0), turning[0].duration = 2;
    turning[1].position = {5, 1, 0}, turning[1].orientation = glm::dquat(0.7, 0, 0.7, 0), turning[1].fov_degrees = 40;
    turning[2].position = {0, 2, -5}, turning[2].orientation = glm::dquat(0, 0, 1, 0);
    const strata::CameraPath squad = strata::CameraPath::from_keys(turning);
    write_text(dir / "path_json/squad.json", squad.to_json());

    std::vector<Keyframe> orbit(4);
    for (int k = 0; k < 4; ++k) {
        const double a = k * 1.5;
        orbit[k].position = {5 * std::cos(a), 1, 5 * std::sin(a)};
        orbit[k].target = glm::dvec3(0, 0, 0);
        orbit[k].handles.out = orbit[k].position + glm::dvec3(0, 1, 0);
    }
    strata::PathOptions options;
    options.positions = strata::Interpolation::bezier;
    options.orientations = strata::OrientationInterpolation::look_at;
    options.easing = strata::Easing::ease_in_out;
    options.ease_seconds = 1;
    options.total_duration = 12;
    options.up = {0, 0, 1};
    write_text(dir / "path_json/orbit.json", strata::CameraPath::from_keys(orbit, options).to_json());
    options = {};
    options.positions = strata::Interpolation::linear;
    options.orientations = strata::OrientationInterpolation::slerp;
    options.constant_speed = false;
    options.easing = strata::Easing::ease_out;
    write_text(dir / "path_json/linear.json", strata::CameraPath::from_keys(turning, options).to_json());

    std::ostringstream keys, frames;
    strata::write_osg_path(squad, keys);
    strata::write_osg_path(squad, frames, 4.0);
    write_text(dir / "osg_path/keys.path", keys.str());
    write_text(dir / "osg_path/frames.path", frames.str());
    // As osgViewer's recorder writes: a clock time that does not start at 0, blank lines between.
    write_text(dir / "osg_path/recorded.path",
               "1520.25 0 -10 2 0.7071067811865476 0 0 0.7071067811865476\n\n"
               "1521.5 1e-3 -9.5 2.25 0.6 0 0 0.8\n1523 1.5 -8 3 0.5 0.1 0 0.86\n");
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: fuzz_make_seeds DIR\n");
        return 2;
    }
    const fs::path dir = argv[1];
    mesh_seeds(dir);
    hlod_seeds(dir);
    path_seeds(dir);
    return 0;
}
