// Internal to mesh import: the per-format readers that read_mesh() dispatches to, and the small pieces
// they share (error reporting, progress ticks, text scanning, number parsing). Not a public API.
#pragma once

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "preprocess/mesh.h"
#include "preprocess/progress.h"
#include "preprocess/triangle_source.h"

namespace strata::detail {

// One whole input file, in memory, plus what every reader needs to report about it.
struct ReadInput {
    const std::filesystem::path& path;
    std::string name;  // path as the user gave it; every error message starts with it
    const char* data = nullptr;
    size_t size = 0;
    const Progress& progress;
    std::vector<std::string>* warnings = nullptr;  // where warn() goes; null: nobody asked
    // Mesh::origin to store positions against; null: picked from the file's first vertex (Coordinates).
    const std::array<double, 3>* origin = nullptr;

    [[noreturn]] void fail(std::string_view what) const {
        throw InputError(name + ": " + std::string(what));
    }
    // Something read past rather than refused, which the user may want to know about.
    void warn(std::string_view what) const {
        if (warnings) warnings->push_back(name + ": " + std::string(what));
    }
    // Checked before anything is allocated, so a lying header count fails at once, never by running out
    // of memory: `room` is the most records the `bytes_left` could hold.
    void require_room(uint64_t count, std::string_view noun, size_t bytes_left, uint64_t room) const {
        if (count > room)
            fail("expected " + std::to_string(count) + " " + std::string(noun) + ", but only " +
                 std::to_string(bytes_left) + " bytes are left, room for at most " + std::to_string(room));
    }
};

// The most records of `values` numbers each that `bytes_left` of text can hold: every value takes two
// bytes at least (a digit and a separator; the file's last value needs no separator).
inline uint64_t text_room(size_t bytes_left, size_t values) { return (uint64_t(bytes_left) + 1) / (2 * values); }

// Entry points, one per format. Each returns the mesh as the file lists it (not yet welded) and throws
// InputError for malformed input. read_mesh() picks one by content, then welds.
Mesh read_ply(const ReadInput& input);
Mesh read_obj(const ReadInput& input);
Mesh read_off(const ReadInput& input);
Mesh read_stl(const ReadInput& input);

// A file read as it lists its vertices and triangles, not welded, its positions against `origin` when
// that is given (read_mesh() is this plus weld()).
Mesh read_mesh_as_listed(const std::filesystem::path& path, const Progress& progress, std::vector<std::string>& warnings,
                         const std::array<double, 3>* origin);

// A binary PLY as a stream of triangles (triangle_source.h), its vertices looked up through a cache of
// about `cache_bytes` that lives while for_each() runs; null when the file is not a binary PLY whose
// vertex records have a fixed size and whose vertex and face elements can be found without reading
// the elements before them (the caller then reads it into memory). Throws InputError naming the file
// for a malformed header or a file shorter than its vertices.
std::unique_ptr<TriangleSource> open_ply_stream(const std::filesystem::path& path, const std::string& name,
                                                const std::array<double, 3>* origin, uint64_t cache_bytes,
                                                std::vector<std::string>& warnings);

// What one tile of a model has, for common_attributes().
struct TileAttributes {
    std::string name;
    AttributeSet has;
    std::string texture;
};
// The attributes every tile has, warning for each that only some have; throws InputError naming two
// tiles that name different textures.
ModelAttributes common_attributes(const std::vector<TileAttributes>& tiles, std::vector<std::string>& warnings);

// Appends `n` floats with −0 made +0, so that equal values have equal bytes.
inline void append_canonical(std::vector<float>& out, const float* values, size_t n) {
    for (size_t i = 0; i < n; ++i) out.push_back(values[i] + 0.0f);  // −0 + 0 is +0
}

// The face count a PLY or OFF header gives, for estimating a build's memory before the file is read;
// `input` may hold only the file's first bytes. Throws InputError when the header is not all there
// or is malformed.
uint64_t ply_face_count(const ReadInput& input);
uint64_t off_face_count(const ReadInput& input);

// Asks for transparent huge pages on [data, data + bytes) before its first touch: for arrays of
// hundreds of MB, 4 KB page faults and TLB misses otherwise cost more than the parsing itself.
void advise_huge_pages(const void* data, size_t bytes);

// Reserves a large vector's storage untouched, so advise_huge_pages() still applies to it.
template <class T>
void reserve_huge(std::vector<T>& values, size_t count) {
    values.reserve(count);
    advise_huge_pages(values.data(), count * sizeof(T));
}

// Index of the first vertex (xyz triple) with a NaN or infinite coordinate, or `count` if all are finite.
size_t first_non_finite(const float* xyz, size_t count);

// Reports "read" progress and polls cancellation every few MB, however often at() is called.
class ReadTicker {
public:
    static constexpr size_t kStep = size_t(4) << 20;

    ReadTicker(const Progress& progress, size_t total) : progress_(progress), total_(total) {}
    void at(size_t done) {
        if (done >= next_) tick(done);
    }
    void finish() { tick(total_); }

private:
    void tick(size_t done) {
        progress_("read", double(done), double(total_), "B");
        progress_.check();
        next_ = done + kStep;
    }
    const Progress& progress_;
    size_t total_;
    size_t next_ = 0;
};

// ---- text scanning --------------------------------------------------------------------------------

inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }
inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// Whether `token` is `lower_case` in any case: some writers shout keywords ("SOLID", "FACET NORMAL").
inline bool is_keyword(std::string_view token, std::string_view lower_case) {
    if (token.size() != lower_case.size()) return false;
    for (size_t i = 0; i < token.size(); ++i)
        if ((token[i] >= 'A' && token[i] <= 'Z' ? char(token[i] - 'A' + 'a') : token[i]) != lower_case[i]) return false;
    return true;
}

// 1-based line number of `at` within [begin, ...), lines ending in LF, CRLF or CR alone: only computed
// when an error needs it.
inline size_t line_number(const char* begin, const char* at) {
    size_t line = 1;
    for (const char* p = begin; p < at; ++p) line += (*p == '\n') || (*p == '\r' && (p + 1 == at || p[1] != '\n'));
    return line;
}

// Splits a line (or any text) into whitespace-separated tokens.
class Tokens {
public:
    Tokens(const char* begin, const char* end) : p_(begin), end_(end) {}
    explicit Tokens(std::string_view text) : p_(text.data()), end_(text.data() + text.size()) {}

    // The next token, or an empty view at the end.
    std::string_view next() {
        while (p_ < end_ && is_space(*p_)) ++p_;
        const char* start = p_;
        while (p_ < end_ && !is_space(*p_)) ++p_;
        return {start, size_t(p_ - start)};
    }
    // Whatever is left, without surrounding blanks (a name that may contain spaces).
    std::string_view rest() {
        while (p_ < end_ && is_space(*p_)) ++p_;
        const char* e = end_;
        while (e > p_ && is_space(e[-1])) --e;
        return {p_, size_t(e - p_)};
    }
    // Skips the rest of the current line (a free-form name such as STL's "solid <name>").
    void skip_line() {
        const void* nl = std::memchr(p_, '\n', size_t(end_ - p_));
        p_ = nl ? static_cast<const char*>(nl) + 1 : end_;
    }
    bool at_end() {
        while (p_ < end_ && is_space(*p_)) ++p_;
        return p_ == end_;
    }
    const char* position() const { return p_; }

private:
    const char* p_;
    const char* end_;
};

// Splits text into lines ending in LF, CRLF or CR alone (classic Mac OS, Rhino 6's PLY headers); the
// returned line excludes its ending.
class Lines {
public:
    Lines(const char* begin, const char* end) : p_(begin), end_(end), next_lf_(find(begin, end, '\n')) {}

    bool next(std::string_view& line) {
        if (p_ >= end_) return false;
        if (next_lf_ < p_) next_lf_ = find(p_, end_, '\n');  // kept across lines: a CR-only file is one scan
        const char* start = p_;
        const char* stop = find(p_, next_lf_, '\r');
        ending_ = stop;
        if (stop == end_) p_ = end_;
        else if (*stop == '\r' && stop + 1 < end_ && stop[1] == '\n') p_ = stop + 2;
        else p_ = stop + 1;
        ++line_;
        line = {start, size_t(stop - start)};
        return true;
    }
    size_t line() const { return line_; }  // 1-based number of the line last returned
    const char* position() const { return p_; }
    const char* ending() const { return ending_; }  // where the last line's ending starts (or the end)

private:
    static const char* find(const char* from, const char* to, char c) {
        const void* hit = std::memchr(from, c, size_t(to - from));
        return hit ? static_cast<const char*>(hit) : to;
    }
    const char* p_;
    const char* end_;
    const char* next_lf_;  // the first LF at or after p_, or end_
    const char* ending_ = nullptr;
    size_t line_ = 0;
};

// ---- numbers --------------------------------------------------------------------------------------
// std::from_chars: locale-independent and exact. It rejects a leading '+', which some writers emit.

template <class T>
bool parse_number(std::string_view token, T& out) {
    if (!token.empty() && token[0] == '+') token.remove_prefix(1);
    if (token.empty()) return false;
    auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), out);
    return ec == std::errc() && end == token.data() + token.size();
}

// The origin an axis gets from the first vertex's coordinate: truncated toward zero to a multiple of
// 1024, so positions stay within about 1 km of it wherever the data lies near its first vertex (a
// float there resolves 0.1 mm), and data within 1024 units of zero keeps origin 0, read exactly as a
// float reader always read it. Exact in double: the steps are powers of two. Beyond 2^32 (no map
// projection's metres reach that) the origin stays 0 too: such a first vertex is an outlier or the
// data is not in metres, and an origin there would round every vertex near zero away.
inline double origin_near(double first) {
    constexpr double kStep = 1024, kFarthest = 4294967296.0;
    return std::abs(first) < kFarthest ? std::trunc(first / kStep) * kStep : 0.0;
}

// Positions relative to Mesh::origin, which each axis takes from the first coordinate it sees
// (origin_near) unless the caller fixed it (the tiles of one model share the first tile's, so a
// border vertex that two tiles repeat reads as the same float in both). The subtraction is done in
// double, before the value is rounded to a float.
class Coordinates {
public:
    explicit Coordinates(const ReadInput& input) {
        if (input.origin) origin_ = *input.origin, picked_.fill(true);
    }
    // A value already parsed (binary data, integers).
    float relative(double value, int axis) {
        if (!picked_[axis]) pick(value, axis);
        return float(value - origin_[axis]);
    }
    // A text value; false if it is no number. Where the origin is 0 a value that the file declares
    // float (every text format but a PLY 'double') is parsed as a float, so a float that to_chars wrote
    // reads back bit-exact; otherwise as a double, and the origin subtracted before rounding.
    bool parse(std::string_view token, int axis, float& out, bool float_text = true) {
        double value = 0;
        if (!picked_[axis]) {
            if (!parse_number(token, value)) return false;
            pick(value, axis);
        }
        if (float_text && origin_[axis] == 0) return parse_number(token, out);
        if (!parse_number(token, value)) return false;
        out = float(value - origin_[axis]);
        return true;
    }
    const std::array<double, 3>& origin() const { return origin_; }

private:
    void pick(double first, int axis) {
        origin_[axis] = origin_near(first);
        picked_[axis] = true;
    }
    std::array<double, 3> origin_{};
    std::array<bool, 3> picked_{};
};

// A float 0..1 colour channel as a byte, clamped, NaN as 0.
inline uint8_t unit_to_byte(double value) {
    if (!(value > 0.0)) return 0;
    if (value >= 1.0) return 255;
    return uint8_t(value * 255.0 + 0.5);
}

// A colour channel as a byte: a 0..255 value when `bytes` (a writer's integers), else a 0..1 one; clamped,
// NaN as 0 (a float-to-byte cast of NaN or of a value out of range is undefined).
inline uint8_t color_byte(double value, bool bytes) {
    if (!bytes) return unit_to_byte(value);
    if (!(value > 0.0)) return 0;
    return uint8_t(std::min(value, 255.0));
}

// Quotes a token for an error message, shortened so a binary blob cannot flood the message.
inline std::string quoted(std::string_view token) {
    constexpr size_t kMax = 40;
    std::string out = "'";
    for (char c : token.substr(0, kMax)) out += (static_cast<unsigned char>(c) < 32 ? '?' : c);
    if (token.size() > kMax) out += "...";
    return out + "'";
}

}  // namespace strata::detail
