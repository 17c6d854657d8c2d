// GPU buffers with immutable storage (glNamedBufferStorage): vertex and index data pulled by shaders
// from storage buffers, uniform blocks, indirect draw commands.
#pragma once

#include <cstddef>
#include <cstdint>
#include <ranges>
#include <type_traits>
#include <vector>

#include "engine/gl/gl.h"
#include "engine/gl/object_name.h"

namespace strata::gl {

template <class T>
concept BufferElement = std::is_trivially_copyable_v<T>;

// A std::vector, std::array, std::span, ... of plain values: what can be copied into a buffer as bytes.
template <class R>
concept BufferData = std::ranges::contiguous_range<R> && std::ranges::sized_range<R> &&
                     BufferElement<std::ranges::range_value_t<R>>;

// Storage flags: contents fixed at creation, or replaceable with upload().
inline constexpr GLbitfield kFixedStorage = 0, kDynamicStorage = GL_DYNAMIC_STORAGE_BIT;

// The most bytes one storage-buffer binding may hold (GL_MAX_SHADER_STORAGE_BLOCK_SIZE). Needs a
// current context.
uint64_t max_storage_block_bytes();

class Buffer {
public:
    Buffer() = default;  // no buffer
    // `storage_flags` as glNamedBufferStorage takes them: GL_DYNAMIC_STORAGE_BIT allows upload(),
    // 0 makes the contents fixed at creation. `initial_data` (size_bytes long) may be null.
    Buffer(std::size_t size_bytes, GLbitfield storage_flags, const void* initial_data = nullptr);
    template <BufferData R>
    Buffer(const R& data, GLbitfield storage_flags)
        : Buffer(byte_size(data), storage_flags, std::ranges::data(data)) {}

    // Replaces bytes [offset, offset + size) (needs GL_DYNAMIC_STORAGE_BIT). Throws GlError when the
    // range is outside the buffer or the buffer is not dynamic.
    void upload(std::size_t offset_bytes, const void* data, std::size_t size_bytes);
    template <BufferData R>
    void upload(const R& data, std::size_t offset_bytes = 0) {
        upload(offset_bytes, std::ranges::data(data), byte_size(data));
    }

    // Copies bytes back to the CPU (glGetNamedBufferSubData: waits for the GPU), shaders' writes to
    // it included. Throws GlError when the range is outside the buffer.
    void download(std::size_t offset_bytes, void* out, std::size_t size_bytes) const;
    template <BufferElement T>
    std::vector<T> download(std::size_t count, std::size_t offset_bytes = 0) const {
        std::vector<T> values(count);
        download(offset_bytes, values.data(), count * sizeof(T));
        return values;
    }

    // Binds the whole buffer to an indexed target: GL_SHADER_STORAGE_BUFFER, GL_UNIFORM_BUFFER, ...
    void bind_base(GLenum target, GLuint index) const;

    GLuint id() const { return name_.get(); }
    std::size_t size() const { return size_; }

private:
    template <BufferData R>
    static std::size_t byte_size(const R& data) {
        return std::ranges::size(data) * sizeof(std::ranges::range_value_t<R>);
    }
    void check_range(const char* operation, std::size_t offset_bytes, std::size_t size_bytes) const;

    ObjectName<DeleteBuffer> name_;
    std::size_t size_ = 0;
    GLbitfield storage_flags_ = 0;
};

}  // namespace strata::gl
