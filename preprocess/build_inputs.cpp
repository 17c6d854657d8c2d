#include "preprocess/build_inputs.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "preprocess/byte_size.h"
#include "preprocess/mesh.h"
#include "preprocess/mesh_io.h"
#include "preprocess/mesh_readers.h"
#include "preprocess/triangle_spill.h"

namespace strata {
namespace {

// Peak resident bytes per input triangle of read + build: /usr/bin/time -v's maximum resident set of
// `strata build` on bumpy grids from binary PLY (positions only, about half as many vertices as
// triangles) was 23 MB at 0.18 M triangles, 99 MB at 2 M and 349 MB at 8 M, the same for the 8 M
// cut into 4 tiles: 42.6 bytes per triangle above about 15 MB (the builder's own figure on a 19.3 M
// triangle scan: 41). A little margin on both; colours, normals and UVs cost more than this counts.
constexpr uint64_t kPeakBytesPerTriangle = 44;
// A streamed triangle's share of the buffers, before the limit caps them: the vertex cache (about half
// a 12-byte vertex a triangle, with room) and the triangle spill (three 12-byte corners).
constexpr uint64_t kStreamBytesPerTriangle = 48;
// Temporary disk a triangle needs at the peak: its three spilled corners, while level L's cubes are
// made from them (the spill's disk is given back as they grow, and they are smaller), plus level L's
// border listings (about 4 bytes a triangle). Measured on 328 M triangles with positions alone: 35.9.
constexpr uint64_t kTempBytesBesideCorners = 6;
// Input triangles a build gets through per CPU-second, all of it (reading, partition, every level and
// its error bound, writing): 0.10 M on the 19.3 M-triangle derived bunny, on the 5.76 M-triangle
// trinidad.nc terrain and on bunny.off (bench_build; a 2-core EPYC with an SSD). The error bound takes
// about four fifths of it; before it, 0.5 M.
constexpr double kTrianglesPerCpuSecond = 0.1e6;


bool is_list(const std::string& argument) { return argument.size() > 1 && argument[0] == '@'; }

std::vector<std::filesystem::path> read_list(const std::filesystem::path& list) {
    std::ifstream file(list, std::ios::binary);
    if (!file) throw InputError(list.string() + ": cannot read the list of inputs (" + std::strerror(errno) + ")");
    std::stringstream text;
    text << file.rdbuf();
    const std::string bytes = text.str();
    std::vector<std::filesystem::path> files;
    detail::Lines lines(bytes.data(), bytes.data() + bytes.size());
    std::string_view line;
    while (lines.next(line)) {
        const std::string_view name = detail::Tokens(line).rest();
        if (name.empty() || name[0] == '#') continue;
        files.push_back(list.parent_path() / std::filesystem::path(std::string(name)));
    }
    if (files.empty()) throw InputError(list.string() + ": the list names no input files");
    return files;
}

}  // namespace

std::vector<std::filesystem::path> expand_inputs(const std::vector<std::string>& arguments) {
    std::vector<std::filesystem::path> files;
    for (const std::string& argument : arguments) {
        if (!is_list(argument)) {
            files.emplace_back(argument);
            continue;
        }
        std::vector<std::filesystem::path> listed = read_list(argument.substr(1));
        files.insert(files.end(), listed.begin(), listed.end());
    }
    return files;
}

std::string source_name(const std::vector<std::string>& arguments, size_t file_count) {
    if (arguments.size() == 1) {
        const std::string& only = arguments.front();
        return std::filesystem::path(is_list(only) ? only.substr(1) : only).filename().string();
    }
    return std::to_string(file_count) + " files";
}

MemoryEstimate estimate_build(const std::vector<std::filesystem::path>& files, uint64_t limit) {
    MemoryEstimate estimate;
    uint64_t streamed = 0;
    std::vector<std::string> ignored;  // the build itself reports what the headers hold
    for (const std::filesystem::path& file : files) {
        const TriangleEstimate counted = estimate_triangles(file);
        estimate.triangles += counted.triangles;
        estimate.guessed |= !counted.from_header;
        std::unique_ptr<TriangleSource> stream;
        try {
            stream = detail::open_ply_stream(file, file.string(), nullptr, 0, ignored);
        } catch (const InputError&) {
            // read whole, which reports what is wrong with it
        }
        (stream ? streamed : estimate.in_memory_triangles) += counted.triangles;
        // A file read whole tells its attributes only once read: positions alone are assumed.
        const uint64_t corner = build::CornerLayout{stream ? stream->attributes() : AttributeSet{}}.bytes();
        estimate.temp_bytes += (3 * corner + kTempBytesBesideCorners) * counted.triangles;
    }
    estimate.cpu_seconds = double(estimate.triangles) / kTrianglesPerCpuSecond;
    estimate.bytes = kPeakBytesPerTriangle * estimate.in_memory_triangles +
                     std::min(limit / 2, kStreamBytesPerTriangle * (streamed + estimate.in_memory_triangles));
    return estimate;
}

void check_memory(const MemoryEstimate& estimate, uint64_t limit, const std::string& limit_name) {
    if (estimate.bytes <= limit) return;
    throw InputError("needs about " + describe_bytes(estimate.bytes) + " in memory for " +
                     std::to_string(estimate.in_memory_triangles) + (estimate.guessed ? " (estimated)" : "") +
                     " triangles read whole into memory, more than " + limit_name + " (" + describe_bytes(limit) +
                     "); binary PLY streams from disk in bounded memory: convert the input to it");
}

void check_temp_disk(const MemoryEstimate& estimate, const std::filesystem::path& folder, uint64_t held) {
    std::error_code ec;
    const std::filesystem::space_info space = std::filesystem::space(folder.empty() ? "." : folder, ec);
    // A folder that does not exist fails when made; what a killed build holds there already counts.
    if (ec || space.available + held >= estimate.temp_bytes) return;
    throw InputError((folder.empty() ? std::string(".") : folder.string()) + ": the build needs about " +
                     describe_bytes(estimate.temp_bytes) + " of temporary disk here, and only " +
                     describe_bytes(space.available) + " is free; free some or choose another folder with --temp");
}

OpenInput input_from_files(const std::vector<std::filesystem::path>& files, uint64_t memory, const Progress& progress,
                           std::vector<std::string>& warnings) {
    return [files, memory, &progress, &warnings] {
        BuildInput input;
        input.sources = open_sources(files, memory / 4, progress, warnings);
        input.model = common_attributes(input.sources, warnings);
        return input;
    };
}

}  // namespace strata
