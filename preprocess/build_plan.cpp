#include "preprocess/build_plan.h"

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

#include "preprocess/atomic_file.h"
#include "preprocess/byte_packing.h"
#include "preprocess/job_files.h"
#include "preprocess/mesh.h"

namespace strata::build {
namespace {

constexpr uint32_t kPlanMagic = 0x4C504A53;  // "SJPL"
constexpr uint32_t kPlanVersion = 3;  // 2: the input's bounding box; 3: lock_boundary
constexpr size_t kMaxStringBytes = size_t(1) << 20;

// The level-(l−1) blocks that the parents of block `block`'s level-l cubes can lie in: up to two a side,
// since the block grid is offset by half a block (Frame::block_of).
void add_parent_blocks(CubeKey block, uint32_t level, const Frame& f, std::vector<CubeKey>& out) {
    const int64_t n = f.block, last_cube = (int64_t(1) << level) - 1;
    const int64_t b[3] = {key_i(block), key_j(block), key_k(block)};
    int64_t low[3], high[3];
    for (int a = 0; a < 3; ++a) {
        const int64_t first = std::max<int64_t>(0, b[a] * n - n / 2), last = std::min(last_cube, b[a] * n + n / 2 - 1);
        low[a] = (first / 2 + n / 2) / n, high[a] = (last / 2 + n / 2) / n;
    }
    for (int64_t k = low[2]; k <= high[2]; ++k)
        for (int64_t j = low[1]; j <= high[1]; ++j)
            for (int64_t i = low[0]; i <= high[0]; ++i) out.push_back(make_key(uint64_t(i), uint64_t(j), uint64_t(k)));
}

void put_settings(ByteWriter& out, const BuildSettings& s) {
    out.put(int32_t(s.levels)), out.put(int32_t(s.block)), out.put(s.ratio), out.put(s.sigma0), out.put(s.error);
    out.put(int32_t(s.leaf_triangles)), out.put(uint8_t(s.lock_boundary));
}

BuildSettings get_settings(ByteReader& in) {
    BuildSettings s;
    s.levels = in.get<int32_t>(), s.block = in.get<int32_t>(), s.ratio = in.get<float>(), s.sigma0 = in.get<float>();
    s.error = in.get<float>(), s.leaf_triangles = in.get<int32_t>(), s.lock_boundary = in.get<uint8_t>();
    return s;
}

void put_header(ByteWriter& out, const HlodHeader& h) {
    out.put(h.flags);
    for (double o : h.origin) out.put(o);
    out.put(h.root_size), out.put(h.max_level), out.put(h.block_size), out.put(h.sigma0), out.put(h.ratio);
    out.put(h.error_limit), out.put(h.input_triangles);
    for (double v : h.bounds_lo) out.put(v);
    for (double v : h.bounds_hi) out.put(v);
    out.put_string(h.source), out.put_string(h.texture);
}

HlodHeader get_header(ByteReader& in) {
    HlodHeader h;
    h.flags = in.get<uint32_t>();
    for (double& o : h.origin) o = in.get<double>();
    h.root_size = in.get<double>(), h.max_level = in.get<uint32_t>(), h.block_size = in.get<uint32_t>();
    h.sigma0 = in.get<float>(), h.ratio = in.get<float>(), h.error_limit = in.get<float>();
    h.input_triangles = in.get<uint64_t>();
    for (double& v : h.bounds_lo) v = in.get<double>();
    for (double& v : h.bounds_hi) v = in.get<double>();
    h.has_bounds = true;
    h.source = in.get_string(kMaxStringBytes), h.texture = in.get_string(kMaxStringBytes);
    return h;
}

std::string number(double value) {
    std::ostringstream text;
    text << value;
    return text.str();
}

}  // namespace

std::vector<InputRecord> record_inputs(const std::vector<std::filesystem::path>& files) {
    std::vector<InputRecord> records;
    for (const std::filesystem::path& file : files) {
        struct stat st {};
        if (::stat(file.c_str(), &st) != 0)
            throw InputError(file.string() + ": cannot examine the input (" + std::strerror(errno) + ")");
        std::error_code ec;
        const std::filesystem::path absolute = std::filesystem::absolute(file, ec);
        records.push_back(InputRecord{(ec ? file : absolute).lexically_normal().string(), uint64_t(st.st_size),
                                      int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec});
    }
    return records;
}

size_t BuildPlan::stage_of(uint64_t job) const {
    for (size_t s = stages.size(); s-- > 0;)
        if (job >= stages[s].first_job) return s;
    return 0;
}

void plan_stages(BuildPlan& plan, std::vector<CubeKey> leaf_blocks) {
    const uint32_t L = plan.frame.max_level;
    plan.stages.clear();
    plan.stages.push_back(Stage{L, 0, std::move(leaf_blocks)});
    for (uint32_t level = L; level >= 1; --level) {
        Stage next{level, plan.job_count(), {}};
        if (level == L) {
            next.blocks = plan.stages.front().blocks;
        } else {
            for (CubeKey block : plan.stages.back().blocks) add_parent_blocks(block, level + 1, plan.frame, next.blocks);
            std::sort(next.blocks.begin(), next.blocks.end());
            next.blocks.erase(std::unique(next.blocks.begin(), next.blocks.end()), next.blocks.end());
        }
        plan.stages.push_back(std::move(next));
    }
}

std::string settings_differ(const BuildSettings& planned, const BuildSettings& now) {
    auto differ = [](const std::string& name, auto was, auto is) {
        return was == is ? std::string() : name + " " + number(double(was)) + " (now " + number(double(is)) + ")";
    };
    for (const std::string& d : {differ("--levels", planned.levels, now.levels), differ("--block", planned.block, now.block),
                                 differ("--ratio", planned.ratio, now.ratio), differ("--sigma0", planned.sigma0, now.sigma0),
                                 differ("--error", planned.error, now.error),
                                 differ("leaf size", planned.leaf_triangles, now.leaf_triangles)})
        if (!d.empty()) return d;
    if (planned.lock_boundary != now.lock_boundary)
        return planned.lock_boundary ? "--lock-boundary (now without it)" : "no --lock-boundary (now with it)";
    return {};
}

void save_plan(const BuildPlan& p, const std::filesystem::path& path) {
    ByteWriter out;
    out.put(kPlanMagic), out.put(kPlanVersion);
    put_settings(out, p.settings);
    out.put(uint32_t(p.inputs.size()));
    for (const InputRecord& r : p.inputs) out.put_string(r.path), out.put(r.size), out.put(r.modified_ns);
    for (double o : p.frame.origin) out.put(o);
    out.put(p.frame.root_size), out.put(p.frame.max_level), out.put(p.frame.block), out.put(p.frame.sigma0);
    put_header(out, p.header);
    out.put(uint8_t(p.kept.normals)), out.put(uint8_t(p.kept.colors)), out.put(uint8_t(p.kept.uvs));
    out.put(uint32_t(p.notes.size()));
    for (const std::string& note : p.notes) out.put_string(note);
    out.put(uint64_t(p.spill_index.size()));
    out.put_bytes(p.spill_index.data(), p.spill_index.size());
    out.put(uint32_t(p.stages.size()));
    for (const Stage& s : p.stages) {
        out.put(s.level), out.put(s.first_job), out.put(uint64_t(s.blocks.size()));
        out.put_bytes(s.blocks.data(), s.blocks.size() * sizeof(CubeKey));
    }
    out.put(p.read_seconds), out.put(p.spill_seconds), out.put(p.spill_memory_bytes), out.put(p.source_memory_bytes);
    out.put(crc32c(out.bytes.data(), out.bytes.size()));
    AtomicOutputFile file(path);
    file.write(out.bytes.data(), out.bytes.size());
    file.commit();
}

BuildPlan load_plan(const std::filesystem::path& path) {
    std::ifstream stream(path, std::ios::binary);
    if (!stream) throw std::runtime_error(path.string() + ": cannot open the build's plan (" + std::strerror(errno) + ")");
    const std::vector<uint8_t> bytes{std::istreambuf_iterator<char>(stream), std::istreambuf_iterator<char>()};
    const std::string what = path.string() + " (the build's plan)";
    uint32_t stored = 0;
    if (bytes.size() >= 4) std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
    if (bytes.size() < 12 || crc32c(bytes.data(), bytes.size() - 4) != stored)
        throw DamagedWork(what + ": damaged (checksum mismatch); remove it (strata build --clean) and build again");
    ByteReader in{std::span<const uint8_t>(bytes).first(bytes.size() - 4), what};
    if (in.get<uint32_t>() != kPlanMagic || in.get<uint32_t>() != kPlanVersion)
        throw DamagedWork(what + ": not a plan of this Strata; remove it (strata build --clean) and build again");
    BuildPlan p;
    p.settings = get_settings(in);
    for (uint32_t n = in.get<uint32_t>(); n > 0; --n) {
        InputRecord r;
        r.path = in.get_string(kMaxStringBytes), r.size = in.get<uint64_t>(), r.modified_ns = in.get<int64_t>();
        p.inputs.push_back(r);
    }
    for (double& o : p.frame.origin) o = in.get<double>();
    p.frame.root_size = in.get<double>(), p.frame.max_level = in.get<uint32_t>(), p.frame.block = in.get<uint32_t>();
    p.frame.sigma0 = in.get<float>();
    p.header = get_header(in);
    p.kept.normals = in.get<uint8_t>(), p.kept.colors = in.get<uint8_t>(), p.kept.uvs = in.get<uint8_t>();
    for (uint32_t n = in.get<uint32_t>(); n > 0; --n) p.notes.push_back(in.get_string(kMaxStringBytes));
    const std::span<const uint8_t> index = in.get_bytes(in.get<uint64_t>());
    p.spill_index.assign(index.begin(), index.end());
    for (uint32_t n = in.get<uint32_t>(); n > 0; --n) {
        Stage s;
        s.level = in.get<uint32_t>(), s.first_job = in.get<uint64_t>();
        const std::span<const uint8_t> keys = in.get_bytes(in.get<uint64_t>() * sizeof(CubeKey));
        s.blocks.resize(keys.size() / sizeof(CubeKey));
        if (!keys.empty()) std::memcpy(s.blocks.data(), keys.data(), keys.size());
        p.stages.push_back(std::move(s));
    }
    p.read_seconds = in.get<double>(), p.spill_seconds = in.get<double>();
    p.spill_memory_bytes = in.get<uint64_t>(), p.source_memory_bytes = in.get<uint64_t>();
    return p;
}

std::string describe_jobs(const BuildPlan& p) {
    std::ostringstream text;
    text << "# strata build --run-blocks DIR FIRST-LAST runs jobs FIRST..LAST; a stage's jobs need every job\n"
            "# of the stages above it finished. stage  level  first  last  what\n";
    for (size_t s = 0; s < p.stages.size(); ++s) {
        const Stage& stage = p.stages[s];
        text << "stage " << s << " " << stage.level << " " << stage.first_job << " "
             << stage.first_job + stage.blocks.size() - 1
             << (s == 0 ? "  level " + std::to_string(stage.level) + "'s cubes from the input's triangles"
                        : "  simplify level " + std::to_string(stage.level) + " into level " + std::to_string(stage.level - 1))
             << "\n";
    }
    return text.str();
}

}  // namespace strata::build
