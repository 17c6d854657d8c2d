// DrawContext's submissions: the only place a scene's drawables reach GL through.
#include "engine/render/draw_context.h"

namespace strata {

namespace {

GLenum gl_primitive(Primitive primitive) { return primitive == Primitive::lines ? GL_LINES : GL_TRIANGLES; }

}  // namespace

void DrawContext::bind_resources(const DrawCall& call) {
    call.program.use();
    for (uint32_t binding = 0; binding < kStorageBindings; ++binding)
        if (call.storage[binding]) call.storage[binding]->bind_base(GL_SHADER_STORAGE_BUFFER, binding);
    for (uint32_t unit = 0; unit < kTextureUnits; ++unit)
        if (call.textures[unit]) glBindTextureUnit(unit, call.textures[unit]);
}

void DrawContext::apply(const DrawCall& call) {
    bind_resources(call);
    vertex_array.bind();
    if (call.indices) glVertexArrayElementBuffer(vertex_array.id(), call.indices->id());
    if (call.wireframe) glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
    ++stats.draw_calls;
}

void DrawContext::restore(const DrawCall& call) {
    if (call.wireframe) glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    if (call.indices) glVertexArrayElementBuffer(vertex_array.id(), 0);
}

void DrawContext::draw_elements(const DrawCall& call, uint32_t index_count) {
    apply(call);
    glDrawElements(gl_primitive(call.primitive), GLsizei(index_count), GL_UNSIGNED_INT, nullptr);
    restore(call);
}

void DrawContext::draw_indirect(const DrawCall& call, const gl::Buffer& commands, uint64_t first, uint32_t count) {
    apply(call);
    glBindBuffer(GL_DRAW_INDIRECT_BUFFER, commands.id());
    glMultiDrawElementsIndirect(gl_primitive(call.primitive), GL_UNSIGNED_INT,
                                reinterpret_cast<const void*>(first * sizeof(IndexedDrawCommand)), GLsizei(count), 0);
    glBindBuffer(GL_DRAW_INDIRECT_BUFFER, 0);
    restore(call);
}

void DrawContext::draw_instanced(const DrawCall& call, uint32_t vertices, uint32_t instances) {
    apply(call);
    glDrawArraysInstanced(gl_primitive(call.primitive), 0, GLsizei(vertices), GLsizei(instances));
    restore(call);
}

void DrawContext::dispatch(const DrawCall& call, uint32_t groups) {
    bind_resources(call);
    glDispatchCompute(groups, 1, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
}

}  // namespace strata
