// Sizes in bytes as people write them ("2G", "512M", "1.5G"): the grammar of `strata build --memory`
// and of strata.build{memory = ...}, parsed in one place.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace strata {

// A size in bytes: a positive number, optionally with a decimal fraction, then optionally one binary
// suffix in either case: K = 2^10, M = 2^20, G = 2^30, T = 2^40 bytes ("2G", "512m", "1.5G", "4096").
// A fraction of a byte is dropped. Throws std::invalid_argument naming `text` for anything else
// (a sign, an exponent, "GB", zero, more than 2^63 bytes).
uint64_t parse_byte_size(std::string_view text);

// "3.1 GiB", "512 MiB", "800 B": a size for messages (one decimal below 100 of a unit).
std::string describe_bytes(uint64_t bytes);

// The memory a build may use when not told: a quarter of the machine's physical memory.
uint64_t default_memory_limit();

// The most memory this process has held resident so far (its peak RSS).
uint64_t peak_resident_bytes();

}  // namespace strata
