// Little-endian byte packing for the files Strata writes (the .hlod's sections, the build's plan and
// job files): values appended to a byte vector, and read back with every read checked against the
// end, so a short or lying file is an error naming it, never a read past its bytes.
#pragma once

#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace strata {

// Signed residuals as unsigned values small when the residual is small (0, −1, 1, −2 … → 0, 1, 2, 3 …),
// what the codecs' byte streams and bit classes pack.
inline uint32_t zigzag(int32_t v) { return (uint32_t(v) << 1) ^ uint32_t(v >> 31); }
inline int32_t unzigzag(uint32_t z) { return int32_t(z >> 1) ^ -int32_t(z & 1); }

class ByteWriter {
public:
    template <class T>
    void put(T value) {
        static_assert(std::is_trivially_copyable_v<T>);
        size_t at = bytes.size();
        bytes.resize(at + sizeof(T));
        std::memcpy(bytes.data() + at, &value, sizeof(T));  // x86-64 and aarch64 are little-endian
    }
    void put_bytes(const void* data, size_t size) {
        const auto* p = static_cast<const uint8_t*>(data);
        bytes.insert(bytes.end(), p, p + size);
    }
    void put_string(const std::string& s) {
        put(uint32_t(s.size()));
        put_bytes(s.data(), s.size());
    }
    std::vector<uint8_t> bytes;
};

class ByteReader {
public:
    ByteReader(std::span<const uint8_t> bytes, std::string what) : bytes_(bytes), what_(std::move(what)) {}
    template <class T>
    T get() {
        need(sizeof(T));
        T value;
        std::memcpy(&value, bytes_.data() + at_, sizeof(T));
        at_ += sizeof(T);
        return value;
    }
    std::span<const uint8_t> get_bytes(size_t size) {
        need(size);
        auto span = bytes_.subspan(at_, size);
        at_ += size;
        return span;
    }
    std::string get_string(size_t max_bytes) {
        uint32_t size = get<uint32_t>();
        if (size > max_bytes) throw std::runtime_error(what_ + ": name of " + std::to_string(size) + " bytes");
        auto span = get_bytes(size);
        return std::string(span.begin(), span.end());
    }
    size_t position() const { return at_; }
    bool at_end() const { return at_ == bytes_.size(); }

private:
    void need(size_t size) const {
        if (size > bytes_.size() - at_) throw std::runtime_error(what_ + " ends early");
    }
    std::span<const uint8_t> bytes_;
    std::string what_;
    size_t at_ = 0;
};

}  // namespace strata
