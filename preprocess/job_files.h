// The files a build's jobs hand each other in its work folder (hlod_builder.cpp runs the jobs, in one
// process or many): the cubes a job made for the next level with the border points they list, and
// the payloads it encoded. Each is written whole under a temporary name and renamed into place, so a
// file that exists is complete, and a job is finished exactly when its file exists; each section
// carries a CRC, so a damaged file is an error naming it, never a wrong model.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <vector>

#include "preprocess/block_step.h"
#include "preprocess/border_table.h"
#include "preprocess/build_cubes.h"
#include "preprocess/hlod_format.h"
#include "preprocess/open_boundary.h"

namespace strata::build {

// A work folder's file that is not what the build wrote (cut short, a checksum that disagrees): the
// work cannot go on from it, only start over.
class DamagedWork : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Writes the level-`level` cubes one job made (a leaf job: its block's level-L cubes; the job of a
// level-(l+1) block: the parents it made, which lie in up to eight level-l blocks), grouped by block
// and in key order within one, the points they list, and (a leaf job locking the boundary) the edges
// its block uses an odd number of times. Returns the file's size. Throws std::runtime_error naming the
// file when the disk refuses it.
uint64_t write_cube_file(const std::filesystem::path& path, std::vector<CubeRecord> cubes, uint32_t level,
                         const std::vector<BorderEntry>& border, const std::vector<OpenEdge>& odd_edges, const Frame& frame);

// An opened cube file: its index read and checked; sections are read on demand.
class CubeFile {
public:
    // Throws DamagedWork naming the file when it is short or damaged, std::runtime_error when it cannot
    // be opened.
    explicit CubeFile(std::filesystem::path path);

    uint32_t level() const { return level_; }
    // The block's cubes, in key order; none when the job made none there.
    std::vector<CubeRecord> cubes_of(CubeKey block) const;
    uint64_t triangles_of(CubeKey block) const;
    // Every point the file's cubes list.
    std::vector<BorderEntry> listings() const;
    // The edges its block's triangles use an odd number of times, as the leaf job listed them.
    std::vector<OpenEdge> odd_edges() const;

private:
    struct Section {
        uint64_t offset = 0, size = 0, count = 0, triangles = 0;
        uint32_t checksum = 0;
    };
    struct BlockSection {
        CubeKey block;
        Section section;
    };
    std::vector<uint8_t> read_section(const Section& s) const;
    template <class T>
    std::vector<T> read_array(const Section& s, const char* what) const;
    const Section* find(CubeKey block) const;

    std::filesystem::path path_;
    FileHandle file_;  // open from the index to the last section read: one open a producer
    uint32_t level_ = 0;
    std::vector<BlockSection> blocks_;  // in block order
    Section listings_, odd_edges_;
};

// Writes the payloads one job encoded, in key order. Returns the file's size.
uint64_t write_payload_file(const std::filesystem::path& path, const std::vector<EncodedCube>& cubes);
// Throws DamagedWork naming the file when it is short or damaged, std::runtime_error when it cannot be
// opened.
std::vector<EncodedCube> read_payload_file(const std::filesystem::path& path);

}  // namespace strata::build
