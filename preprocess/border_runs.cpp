#include "preprocess/border_runs.h"

#include <algorithm>
#include <cstring>

namespace strata::build {
namespace {

void append_run(const RunSpill& listed, CubeKey block, std::vector<BorderEntry>& out) {
    const std::vector<uint8_t> bytes = listed.read(block);
    const size_t first = out.size();
    out.resize(first + bytes.size() / sizeof(BorderEntry));
    if (!bytes.empty()) std::memcpy(&out[first], bytes.data(), bytes.size());
}

}  // namespace

void append_listings(std::vector<BorderEntry>& entries, RunSpill& listed) {
    std::stable_sort(entries.begin(), entries.end(), [](const BorderEntry& a, const BorderEntry& b) { return a.block < b.block; });
    for (size_t first = 0, last; first < entries.size(); first = last) {
        for (last = first; last < entries.size() && entries[last].block == entries[first].block; ++last) {
        }
        listed.append(entries[first].block, &entries[first], (last - first) * sizeof(BorderEntry));
    }
}

BorderTable block_border_table(const RunSpill& listed, CubeKey block, const Frame& f, uint32_t level) {
    const double size = f.cube_size(level);
    const double reach = f.sigma0 * size * 1.001 + size * 1e-4;  // as list_border_points() reaches
    double low[3], high[3];
    for (int a = 0; a < 3; ++a) {
        low[a] = f.block_low(block, a, level) - reach;
        high[a] = low[a] + 2 * reach + f.block * size;
    }
    std::vector<BorderEntry> near;
    const int64_t b[3] = {key_i(block), key_j(block), key_k(block)};
    for (int64_t dk = -1; dk <= 1; ++dk)
        for (int64_t dj = -1; dj <= 1; ++dj)
            for (int64_t di = -1; di <= 1; ++di) {
                if (b[0] + di < 0 || b[1] + dj < 0 || b[2] + dk < 0) continue;
                std::vector<BorderEntry> run;
                append_run(listed, make_key(uint64_t(b[0] + di), uint64_t(b[1] + dj), uint64_t(b[2] + dk)), run);
                for (const BorderEntry& e : run) {
                    float x[3];
                    std::memcpy(x, e.position.data(), 12);
                    bool inside = true;
                    for (int a = 0; a < 3; ++a) inside &= x[a] >= low[a] && x[a] <= high[a];
                    if (inside) near.push_back(e);
                }
            }
    return BorderTable(std::move(near));
}

BorderTable whole_border_table(const RunSpill& listed) {
    std::vector<BorderEntry> all;
    for (CubeKey block : listed.keys()) append_run(listed, block, all);
    return BorderTable(std::move(all));
}

}  // namespace strata::build
