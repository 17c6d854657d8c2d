#include "engine/render/renderer.h"

#include <chrono>
#include <cmath>
#include <limits>

#include "engine/gl/depth_convention.h"
#include "engine/scene/cull_visitor.h"
#include "engine/scene/drawable.h"
#include "engine/stream/stream_cache.h"

namespace strata {

const char* const kShadingGlsl = R"(
layout(std140, binding = 0) uniform Lights {
    vec4 ambient;                 // rgb
    vec4 light_direction[8];      // xyz: world direction the light travels
    vec4 light_radiance[8];       // rgb
    int light_count;
};

// `n`: the unit normal facing the viewer (scans are often open: back faces get light too).
vec3 shade(vec3 base, vec3 n) {
    vec3 c = ambient.rgb * base;
    for (int i = 0; i < light_count; ++i)
        c += base * light_radiance[i].rgb * max(dot(n, -light_direction[i].xyz), 0.0);
    return c;
}
)";

const char* const kSrgbGlsl = R"(
vec3 srgb_to_linear(vec3 c) {
    return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), greaterThan(c, vec3(0.04045)));
}
)";

namespace {

struct LightsBlock {  // std140, as kShadingGlsl declares it
    glm::vec4 ambient;
    glm::vec4 direction[kMaxLights];
    glm::vec4 radiance[kMaxLights];
    int32_t count;
    int32_t pad[3];
};

double milliseconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

Renderer::Renderer()
    : lights_(sizeof(LightsBlock), GL_DYNAMIC_STORAGE_BIT), empty_vertex_array_(gl::VertexArray::create()) {}

void Renderer::upload_lights(const RenderList& list, const Camera& camera) {
    LightsBlock block{};
    // A scene without lights gets a headlight from over the viewer's shoulder and some ambient; one
    // with an ambient light alone is lit by it alone (a draped orthophoto under ambient 1 shows its
    // own colours).
    block.ambient = glm::vec4(list.has_ambient ? list.ambient : glm::vec3(0.15f), 0.0f);
    if (list.lights.empty() && !list.has_ambient) {
        const glm::dvec3 from_above = camera.orientation * glm::normalize(glm::dvec3(0.3, -0.5, -1.0));
        block.direction[0] = glm::vec4(glm::vec3(from_above), 0.0f);
        block.radiance[0] = glm::vec4(0.85f, 0.85f, 0.85f, 0.0f);
        block.count = 1;
    }
    for (const LightItem& light : list.lights) {
        if (block.count == kMaxLights) break;
        block.direction[block.count] = glm::vec4(glm::vec3(light.direction), 0.0f);
        block.radiance[block.count] = glm::vec4(light.radiance, 0.0f);
        ++block.count;
    }
    lights_.upload(0, &block, sizeof block);
    lights_.bind_base(GL_UNIFORM_BUFFER, kLightsBinding);
}

// How many frames ahead predict_motion carries the eye's last step: about a third of a second at 30
// frames a second, what a cube's load takes from a disk under load.
constexpr double kMotionLeadFrames = 10;

std::vector<Lookahead> Renderer::lookahead_for(const Camera& camera, const RenderSettings& s, const glm::dmat4& projection,
                                               bool streaming) {
    const std::optional<std::pair<glm::dvec3, glm::dquat>> last = std::exchange(last_pose_, {{camera.position, camera.orientation}});
    std::vector<Lookahead> views;
    if (!streaming) return views;  // nothing would prefetch
    auto add = [&](const glm::dvec3& position, const glm::dquat& orientation, double fov) {
        auto ahead = std::make_shared<Camera>();
        ahead->set_view(camera);
        ahead->position = position;
        ahead->orientation = glm::normalize(orientation);
        ahead->fov_y_degrees = fov;
        const glm::dmat4 lens = fov == camera.fov_y_degrees ? projection : ahead->projection_matrix(near_, far_);
        views.push_back({ahead, lens * ahead->view_matrix()});
    };
    for (const RenderSettings::Pose& pose : s.upcoming) add(pose.position, pose.orientation, pose.fov_y_degrees);
    if (s.predict_motion && last && last->first != camera.position) {
        const auto& [position, orientation] = *last;
        add(camera.position + kMotionLeadFrames * (camera.position - position),
            glm::slerp(orientation, camera.orientation, 1.0 + kMotionLeadFrames), camera.fov_y_degrees);
    }
    return views;
}

FrameStats Renderer::render(Node& scene, const Camera& camera, gl::Framebuffer& target, const RenderSettings& s) {
    FrameStats stats;
    const auto cull_start = std::chrono::steady_clock::now();
    std::tie(near_, far_) = camera.clip_planes_for(scene.bound());
    orthographic_ = camera.projection == ProjectionKind::orthographic;
    const glm::dmat4 view = camera.view_matrix(), projection = camera.projection_matrix(near_, far_);
    StreamCache* stream = StreamCache::shared_if_made();
    const std::vector<Lookahead> lookahead = lookahead_for(camera, s, projection, stream != nullptr);
    // Before the cull: a full-detail frame loads and evicts while it waits for its cubes.
    const StreamCache::Stats before = stream ? stream->stats() : StreamCache::Stats{};
    for (;;) {
        list_.clear();
        CullVisitor cull(camera, view, projection, list_);
        cull.set_frustum_culling(s.frustum_culling);
        cull.set_lookahead(lookahead);
        cull.set_full_detail(s.full_detail);
        scene.accept(cull);
        stats.nodes_culled = cull.stats().nodes_culled;
        stats.stand_ins = cull.stats().stand_ins;
        stats.fading = cull.stats().fading;
        if (!stream || !s.full_detail || !stream->has_requests()) break;
        stream->wait_for_requests(s.full_detail_timeout);  // then cull again: the view may now refine further
    }
    const bool converged = stats.stand_ins == 0 && stats.fading == 0 && !(stream && stream->has_requests());
    if (stream) {
        stream->update();  // takes in finished loads, starts what this frame asked for
        const StreamCache::Stats streaming = stream->stats();
        stats.loads_pending = streaming.in_flight + streaming.waiting;
        stats.memory_resident = streaming.resident_bytes;
        stats.memory_resident_gpu = streaming.gpu_resident_bytes;
        stats.memory_tables = streaming.held_bytes;
        stats.loaded = streaming.loaded - before.loaded;
        stats.evicted = streaming.evicted - before.evicted;
    }
    frames_unconverged_ = converged ? 0 : frames_unconverged_ + 1;
    stats.frames_unconverged = frames_unconverged_;
    list_.sort();
    stats.cull_ms = milliseconds_since(cull_start);

    const auto draw_start = std::chrono::steady_clock::now();
    target.bind();
    target.clear(s.background);
    upload_lights(list_, camera);
    GLuint timer = 0;
    if (s.measure_gpu_time) {
        glCreateQueries(GL_TIME_ELAPSED, 1, &timer);
        glBeginQuery(GL_TIME_ELAPSED, timer);
    }
    DrawContext context{camera, view, projection, glm::dvec3(glm::inverse(view)[3]), list_, cache_, stats, empty_vertex_array_};
    for (const DrawItem& item : list_.opaque) item.drawable->prepare(context, item);
    for (const DrawItem& item : list_.opaque) item.drawable->draw(context, item);
    if (timer) {
        glEndQuery(GL_TIME_ELAPSED);
        GLuint64 nanoseconds = 0;
        glGetQueryObjectui64v(timer, GL_QUERY_RESULT, &nanoseconds);
        glDeleteQueries(1, &timer);
        stats.gpu_ms = double(nanoseconds) * 1e-6;
    }
    stats.draw_items = list_.opaque.size();
    stats.draw_ms = milliseconds_since(draw_start);
    cache_.end_frame();
    gl::check_gl("drawing the scene");
    return stats;
}

Image Renderer::read_image(gl::Framebuffer& target) const {
    const gl::FramebufferFormat& f = target.format();
    Image image;
    image.width = target.width();
    image.height = target.height();
    image.rgba = target.read_color();
    image.depth = target.read_depth();
    for (float& d : image.depth) {
        if (d == gl::far_plane_depth) d = std::numeric_limits<float>::infinity();
        else if (orthographic_) d = float(far_ - d * (far_ - near_));  // reversed depth is linear here
        else d = float(gl::eye_distance_from_depth(d, near_, far_));
    }
    if (f.normals) image.normals = target.read_normals();
    if (f.level) image.level = target.read_level();
    if (f.node_id) image.node_id = target.read_node_id();
    return image;
}

}  // namespace strata
