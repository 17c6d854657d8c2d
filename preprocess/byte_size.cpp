#include "preprocess/byte_size.h"

#include <sys/resource.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "preprocess/mesh_readers.h"

namespace strata {

namespace {

int suffix_shift(char c) {
    switch (c) {
        case 'k': case 'K': return 10;
        case 'm': case 'M': return 20;
        case 'g': case 'G': return 30;
        case 't': case 'T': return 40;
        default: return -1;
    }
}

}  // namespace

uint64_t parse_byte_size(std::string_view text) {
    const auto bad = [&](const char* why) {
        return std::invalid_argument("'" + std::string(text) + "' is not a size in bytes (" + why + ")");
    };
    std::string_view number = text;
    int shift = 0;
    if (!number.empty() && suffix_shift(number.back()) >= 0) {
        shift = suffix_shift(number.back());
        number.remove_suffix(1);
    }
    // Digits with at most one '.', nothing else: from_chars alone would take "1e9", "inf" or "-1".
    const size_t dot = number.find('.');
    const bool digits_only = number.find_first_not_of("0123456789.") == std::string_view::npos &&
                             (dot == std::string_view::npos || number.find('.', dot + 1) == std::string_view::npos);
    double value = 0;
    if (number.empty() || number == "." || !digits_only || !detail::parse_number(number, value))
        throw bad("expected a number of bytes, optionally with a suffix K, M, G or T, e.g. 2G or 512M");
    const double bytes = std::floor(std::ldexp(value, shift));
    if (!(bytes >= 1)) throw bad("it must be at least 1 byte");
    if (bytes >= std::ldexp(1.0, 63)) throw bad("more than 2^63 bytes");
    return uint64_t(bytes);
}

std::string describe_bytes(uint64_t bytes) {
    static constexpr const char* kUnits[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    double value = double(bytes);
    size_t unit = 0;
    while (value >= 1024 && unit + 1 < std::size(kUnits)) value /= 1024, ++unit;
    char text[32];
    std::snprintf(text, sizeof text, unit > 0 && value < 100 ? "%.1f %s" : "%.0f %s", value, kUnits[unit]);
    return text;
}

uint64_t default_memory_limit() {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page_size = ::sysconf(_SC_PAGE_SIZE);
    if (pages <= 0 || page_size <= 0) return uint64_t(4) << 30;  // unknown: assume a small machine's quarter
    return uint64_t(pages) * uint64_t(page_size) / 4;
}

uint64_t peak_resident_bytes() {
    struct rusage usage {};
    ::getrusage(RUSAGE_SELF, &usage);
    return uint64_t(usage.ru_maxrss) * 1024;  // Linux counts kilobytes
}

}  // namespace strata
