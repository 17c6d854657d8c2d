// What a build takes in, before anything is read: the input arguments (mesh files and @lists of them)
// as the files of one model, the name the model records as its source, and the memory preflight that
// refuses a build the in-core builder cannot fit under its ceiling.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

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
    uint64_t triangles = 0;  // all files together
    uint64_t bytes = 0;      // the build's expected peak resident memory
    bool guessed = false;    // some file's triangles were guessed from its size (no count in its header)
};

// The in-core build's peak memory for these files, from their headers' counts (or sizes), read before
// any file is: every file is opened, so a missing one is an InputError naming it at once.
MemoryEstimate estimate_build_memory(const std::vector<std::filesystem::path>& files);

// Throws InputError when the estimate exceeds `limit`: "needs about 3.1 GiB in memory, more than
// <limit_name>; ...". `limit_name` says where the limit came from ("--memory 2G").
void check_memory(const MemoryEstimate& estimate, uint64_t limit, const std::string& limit_name);

}  // namespace strata
