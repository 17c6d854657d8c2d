// Buffer: creation, uploads, read-back and indexed binding, all through direct state access.
#include "engine/gl/buffer.h"

#include <string>

namespace strata::gl {

uint64_t max_storage_block_bytes() {
    GLint64 bytes = 0;
    glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &bytes);
    return uint64_t(bytes);
}

Buffer::Buffer(std::size_t size_bytes, GLbitfield storage_flags, const void* initial_data)
    : size_(size_bytes), storage_flags_(storage_flags) {
    // GL rejects empty storage; an empty buffer is Buffer{}.
    if (size_bytes == 0) throw GlError("Buffer: size must be at least one byte");
    GLuint name = 0;
    glCreateBuffers(1, &name);
    name_ = ObjectName<DeleteBuffer>(name);
    glNamedBufferStorage(name, static_cast<GLsizeiptr>(size_bytes), initial_data, storage_flags);
    check_gl("glNamedBufferStorage");
}

void Buffer::check_range(const char* operation, std::size_t offset_bytes, std::size_t size_bytes) const {
    if (offset_bytes <= size_ && size_bytes <= size_ - offset_bytes) return;
    throw GlError(std::string("Buffer::") + operation + ": bytes [" + std::to_string(offset_bytes) + ", " +
                  std::to_string(offset_bytes + size_bytes) + ") outside the buffer's " +
                  std::to_string(size_) + " bytes");
}

void Buffer::upload(std::size_t offset_bytes, const void* data, std::size_t size_bytes) {
    check_range("upload", offset_bytes, size_bytes);
    if (!(storage_flags_ & GL_DYNAMIC_STORAGE_BIT))
        throw GlError("Buffer::upload: the buffer was created without GL_DYNAMIC_STORAGE_BIT");
    glNamedBufferSubData(id(), static_cast<GLintptr>(offset_bytes), static_cast<GLsizeiptr>(size_bytes), data);
}

void Buffer::download(std::size_t offset_bytes, void* out, std::size_t size_bytes) const {
    check_range("download", offset_bytes, size_bytes);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);  // storage-buffer writes of earlier draws become visible
    glGetNamedBufferSubData(id(), static_cast<GLintptr>(offset_bytes), static_cast<GLsizeiptr>(size_bytes), out);
}

void Buffer::bind_base(GLenum target, GLuint index) const { glBindBufferBase(target, index, id()); }

}  // namespace strata::gl
