// Cube payload decode speed, one thread: every cube of a .hlod decoded (decode_cube), median of 5 runs.
//
//   bench_decode MODEL.hlod
//
// The payloads are read (and their checksums checked) once, untimed, so the runs measure decoding from
// memory, not the disk. Prints the payload bytes per input triangle, each stream's share of them (as
// stored, from the payload headers, FORMAT.md §5), and decode speed as MB of payload per second (to
// compare with the disk's read speed: decoding must outpace it) and M triangles per second.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <exception>
#include <vector>

#include "preprocess/hlod_format.h"

namespace {

double seconds_to_decode(const std::vector<strata::HlodNode>& nodes, const std::vector<std::vector<uint8_t>>& payloads,
                         uint32_t flags, uint32_t codec, uint64_t& triangles) {
    const auto start = std::chrono::steady_clock::now();
    triangles = 0;
    for (size_t c = 0; c < nodes.size(); ++c) triangles += strata::decode_cube(payloads[c], nodes[c], flags, codec).triangle_count();
    const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - start;
    return elapsed.count();
}

// FORMAT.md §5: the payload header, then each stream's unpacked and stored size.
constexpr size_t kStreamSizesAt = 40;
constexpr const char* kStreamNames[] = {"triangles (a grid's: its cells)", "positions", "normals", "parents", "colours", "UVs", "low bits"};
constexpr size_t kStreams = std::size(kStreamNames);

// Bytes per input triangle, or per DEM sample for a terrain (`unit`).
void print_stream_shares(const std::vector<std::vector<uint8_t>>& payloads, double inputs, const char* unit) {
    std::array<uint64_t, kStreams> stored{};
    uint64_t headers = 0;
    for (const auto& p : payloads) {
        if (p.size() < kStreamSizesAt + 8 * kStreams) continue;  // decode_cube refuses it
        headers += kStreamSizesAt + 8 * kStreams;
        for (size_t s = 0; s < kStreams; ++s) {
            uint32_t size;
            std::memcpy(&size, p.data() + kStreamSizesAt + 8 * s + 4, 4);
            stored[s] += size;
        }
    }
    std::printf("bytes per %s: headers %.3f", unit, double(headers) / inputs);
    for (size_t s = 0; s < kStreams; ++s)
        if (stored[s]) std::printf(", %s %.3f", kStreamNames[s], double(stored[s]) / inputs);
    std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: bench_decode MODEL.hlod\n");
        return 2;
    }
    try {
        const strata::HlodFile file(argv[1]);
        std::vector<std::vector<uint8_t>> payloads;
        uint64_t payload_bytes = 0;
        for (const strata::HlodNode& node : file.nodes()) {
            payloads.push_back(file.read_payload(node));
            payload_bytes += node.size;
        }
        uint64_t triangles = 0;
        std::vector<double> runs;
        const strata::HlodHeader& h = file.header();
        for (int run = 0; run < 5; ++run) runs.push_back(seconds_to_decode(file.nodes(), payloads, h.flags, h.payload_codec, triangles));
        std::sort(runs.begin(), runs.end());
        const double median = runs[runs.size() / 2];
        const double input_triangles = double(file.header().input_triangles);
        std::printf("file: %s, %.1f MB (%.3f bytes per input triangle), payloads %.1f MB, %zu cubes, %llu triangles\n",
                    argv[1], double(file.file_size()) / 1e6, double(file.file_size()) / input_triangles,
                    double(payload_bytes) / 1e6, file.nodes().size(), static_cast<unsigned long long>(triangles));
        if (h.terrain) {
            const double samples = double(h.terrain->columns * h.terrain->rows - h.terrain->nodata_samples);
            std::printf("terrain: %.0f samples with a height, payloads %.3f bytes a sample (all levels)\n", samples, double(payload_bytes) / samples);
            print_stream_shares(payloads, samples, "DEM sample");
        } else {
            print_stream_shares(payloads, input_triangles, "input triangle");
        }
        std::printf("decode: median %.3f s: %.0f MB/s of payload, %.1f M triangles/s\n", median,
                    double(payload_bytes) / 1e6 / median, double(triangles) / 1e6 / median);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_decode: %s\n", e.what());
        return 1;
    }
    return 0;
}
