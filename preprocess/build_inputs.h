// What a build takes in, before anything is read: the input arguments (mesh files and @lists of them)
// as the files of one model, the name the model records as its source, and the preflight that refuses
// at once a build that cannot fit under its memory ceiling or in its temporary folder.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "preprocess/hlod_builder.h"

namespace strata {

// The files the arguments name, in order: a plain argument is a mesh file; "@LIST" is a text file naming
// one input per line, blank lines and lines starting with '#' skipped, surrounding blanks trimmed, a
// relative path taken relative to the list's folder (a line starting with '@' is a file name, not
// another list). Throws InputError naming the list when it cannot be read or names no file.
std::vector<std::filesystem::path> expand_inputs(const std::vector<std::string>& arguments);

// The model's source name (the .hlod header's `source`): the file's name for one file, the list's name
// for one @list, else "N files".
std::string source_name(const std::vector<std::string>& arguments, size_t file_count);

struct MemoryEstimate {
    uint64_t triangles = 0;            // all files together
    uint64_t in_memory_triangles = 0;  // of the files read whole into memory (all but binary PLY)
    uint64_t bytes = 0;                // the build's expected peak memory, above its fixed overhead (≤ 150 MiB)
    uint64_t temp_bytes = 0;           // its expected peak temporary disk
    double cpu_seconds = 0;            // its expected CPU time, all threads together
    bool guessed = false;              // some file's triangles were guessed from its size (no count in its header)
};

// The build's peak memory and temporary disk for these files under the memory limit `limit` (what
// BuildSettings::memory gives the buffers), from their headers' counts (or sizes), read before any
// file is: every file is opened, so a missing one is an InputError naming it at once. A binary PLY
// streams from disk in memory the limit bounds; other formats are read whole into memory.
MemoryEstimate estimate_build(const std::vector<std::filesystem::path>& files, uint64_t limit);

// Throws InputError when the estimate exceeds `limit`: "needs about 3.1 GiB in memory, more than
// <limit_name>; ...". `limit_name` says where the limit came from ("--memory 2G").
void check_memory(const MemoryEstimate& estimate, uint64_t limit, const std::string& limit_name);

// Throws InputError naming `folder` when it has less free space than the estimate's temporary disk,
// beyond the `held` bytes a resumed build's work folder already takes there.
void check_temp_disk(const MemoryEstimate& estimate, const std::filesystem::path& folder, uint64_t held = 0);

// The input the files hold, for build_hlod to open when it reads it: open_sources() with a quarter of
// `memory` for the streamed files' vertex caches, and common_attributes(). What the readers read past
// goes to `warnings`; it and `progress` must outlive the build.
OpenInput input_from_files(const std::vector<std::filesystem::path>& files, uint64_t memory, const Progress& progress,
                           std::vector<std::string>& warnings);

}  // namespace strata
