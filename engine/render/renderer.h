// The renderer: culls a scene for a camera, then draws its bins into a framebuffer, front to back,
// and reads frames back as Images. Needs a current OpenGL 4.5 context (engine/gl/context.h).
#pragma once

#include <optional>
#include <utility>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/gl/buffer.h"
#include "engine/gl/framebuffer.h"
#include "engine/gl/vertex_array.h"
#include "engine/io/image.h"
#include "engine/render/draw_context.h"
#include "engine/scene/cull_visitor.h"
#include "engine/scene/node.h"
#include "engine/scene/render_list.h"

namespace strata {

struct RenderSettings {
    glm::vec4 background{0.0f, 0.0f, 0.0f, 0.0f};  // linear RGBA
    bool frustum_culling = true;
    // Time the draws on the GPU (a timer query; waits for the GPU to finish the frame).
    bool measure_gpu_time = false;
    // Streamed models (engine/stream): wait until every cube the view selects is resident, then draw,
    // so that the frame does not depend on the cache (captures); a failed load or a view larger than
    // the budget throws std::runtime_error naming it, and so does a wait past the timeout (> 0, in
    // seconds). Otherwise the frame draws what is resident, its stand-ins for the rest, and never waits.
    bool full_detail = false;
    double full_detail_timeout = 0;
    // Poses coming frames will have (a camera path's next frames), each seen with this frame's lens:
    // streamed models prefetch what those views select, into room the budget has free.
    struct Pose {
        glm::dvec3 position;
        glm::dquat orientation;
        double fov_y_degrees;
    };
    std::vector<Pose> upcoming{};
    // Also prefetch for where the eye is heading: this frame's motion since the last one, carried
    // kMotionLeadFrames ahead.
    bool predict_motion = true;
};

class Renderer {
public:
    Renderer();

    // Culls `scene` for `camera` (its clip planes, or ones fitted to the scene) and draws it into
    // `target`, which is bound and cleared first.
    FrameStats render(Node& scene, const Camera& camera, gl::Framebuffer& target, const RenderSettings& settings = {});
    // The last frame's planes as an Image: colour, and whichever data channels `target` has, with
    // depth as eye-space distance.
    Image read_image(gl::Framebuffer& target) const;

    RenderSettings settings;

private:
    void upload_lights(const RenderList& list, const Camera& camera);

    RenderList list_;
    GpuCache cache_;
    gl::Buffer lights_;
    gl::VertexArray empty_vertex_array_;
    double near_ = 0, far_ = 0;  // of the last frame, for depth read-back
    bool orthographic_ = false;
    uint64_t frames_unconverged_ = 0;  // FrameStats::frames_unconverged of the last frame
    // The last frame's camera pose, for predict_motion.
    std::optional<std::pair<glm::dvec3, glm::dquat>> last_pose_;
    // The views RenderSettings::upcoming and predict_motion give this frame (none unless something
    // streams); remembers the camera's pose.
    std::vector<Lookahead> lookahead_for(const Camera& camera, const RenderSettings& settings, const glm::dmat4& projection,
                                         bool streaming);
};

}  // namespace strata
