// strata render: files (HLOD models and meshes) drawn headless into a PNG or OpenEXR image.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include "editor/commands.h"
#include "editor/scene_files.h"
#include "editor/world_file.h"
#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"
#include "engine/io/image.h"
#include "engine/render/renderer.h"
#include "engine/scene/camera.h"
#include "preprocess/elevation_raster.h"

namespace strata::cli {

namespace {

struct RenderOptions {
    std::vector<std::string> files;
    std::string output;
    std::string size = "1280x720";
    std::vector<double> eye, target, up{0, 1, 0};
    double fov = 50;
    bool orthographic = false;
    bool top = false;
    int samples = 4;
    std::string channels = "RGBA,Z";
    std::string compression = "zip";
    std::vector<float> background{0, 0, 0, 0};
    SceneOptions scene;
    MemoryOptions memory;
    bool no_morph = false;
    bool quiet = false;
};

glm::dvec3 vec3_of(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

// Without --eye: the whole scene framed, looking at --target (the scene's centre by default).
void place_camera(Camera& camera, const RenderOptions& o, const Box& bounds) {
    if (o.top) {  // a map: straight down, north up, framed to the scene
        camera.look_at(bounds.center() + glm::dvec3(0, 0, 1), bounds.center(), glm::dvec3(0, 1, 0));
        camera.frame(bounds);
        return;
    }
    const glm::dvec3 up = vec3_of(o.up);
    const glm::dvec3 target = o.target.empty() ? bounds.center() : vec3_of(o.target);
    if (!o.eye.empty()) {
        camera.look_at(vec3_of(o.eye), target, up);
        return;
    }
    // Framed from the front, a little above and to the right, then moved to look at the target.
    const glm::dvec3 front = std::abs(up.z) > 0.9 ? glm::dvec3(0.4, -1, 0.3) : glm::dvec3(0.4, 0.3, 1);
    camera.look_at(bounds.center() + front, bounds.center(), up);
    camera.frame(bounds);
    camera.position += target - bounds.center();
}

int run_render(const RenderOptions& o) {
    const std::filesystem::path output = o.output;
    const std::string extension = output.extension().string();
    if (extension != ".png" && extension != ".exr" && extension != ".tif") {
        std::fprintf(stderr, "strata render: the output must end in .png, .exr or .tif, not '%s'\n", o.output.c_str());
        return kUsage;
    }
    ImageChannels channels = ImageChannel::rgba;
    ExrOptions exr;
    int width = 0, height = 0;
    try {
        std::tie(width, height) = parse_size(o.size);
        if (extension == ".exr") {
            channels = parse_channels(o.channels);
            exr.compression = parse_exr_compression(o.compression);
        }
    } catch (const std::invalid_argument& e) {
        std::fprintf(stderr, "strata render: %s\n", e.what());
        return kUsage;
    }

    if (!apply_memory_options(o.memory, "render")) return kUsage;
    SceneOptions scene_options = o.scene;
    scene_options.morph = !o.no_morph;
    auto context = gl::create_headless_context();
    auto scene = load_scene_files(o.files, scene_options);

    Camera camera;
    camera.width = width;
    camera.height = height;
    camera.fov_y_degrees = o.fov;
    if (o.orthographic || o.top) camera.projection = ProjectionKind::orthographic;
    place_camera(camera, o, scene->bound());

    gl::Framebuffer target({.width = width, .height = height, .samples = o.samples,
                            .normals = channels.contains(ImageChannel::normals),
                            .level = channels.contains(ImageChannel::level),
                            .node_id = channels.contains(ImageChannel::node_id)});
    Renderer renderer;
    RenderSettings settings;
    settings.background = {o.background[0], o.background[1], o.background[2], o.background[3]};
    settings.full_detail = true;  // every cube the view selects, loaded before drawing
    const FrameStats stats = renderer.render(*scene, camera, target, settings);
    const Image image = renderer.read_image(target);
    WorldFiles world;
    if (extension == ".tif") {
        const std::optional<MapPlacement> placement = map_placement(camera, *scene, world.not_written);
        write_geotiff(image, output, placement);
        if (!world.not_written.empty()) std::fprintf(stderr, "strata render: note: no georeference: %s\n", world.not_written.c_str());
        if (!o.quiet && placement) std::printf("%s: placed by its GeoTIFF tags (%s)\n", o.output.c_str(), describe_crs(placement->crs).c_str());
    } else {
        if (extension == ".png") write_png(image, output);
        else write_exr(image, output, channels, exr);
        world = write_world_files(output, camera, *scene);
        if (!world.not_written.empty()) std::fprintf(stderr, "strata render: note: no world file: %s\n", world.not_written.c_str());
    }
    if (!o.quiet)
        std::printf("%s: %dx%d, %llu triangles, %llu cubes, %llu draw calls, cull %.2f ms (%s)\n", o.output.c_str(), width,
                    height, (unsigned long long)stats.triangles, (unsigned long long)stats.cubes,
                    (unsigned long long)stats.draw_calls, stats.cull_ms, context->renderer().c_str());
    if (!o.quiet && !world.written.empty())
        std::printf("%s: placed by %s and %s\n", o.output.c_str(), world.written[0].filename().c_str(), world.written[1].filename().c_str());
    return kOk;
}

}  // namespace

Command add_render(CLI::App& app) {
    auto o = std::make_shared<RenderOptions>();
    CLI::App* sub = app.add_subcommand("render", "Render HLOD models (.hlod) and meshes headless into a PNG or OpenEXR image.");
    sub->add_option("files", o->files, "The .hlod models and meshes (PLY, OBJ, OFF, STL) to draw, each in its own coordinates")
        ->required();
    sub->add_option("-o,--output", o->output,
                    "The image to write: .png (8-bit sRGB), .exr (linear, --channels) or .tif (8-bit sRGB GeoTIFF: a map straight down "
                    "on georeferenced models carries its georeference in its tags)")
        ->required();
    sub->add_option("--size", o->size, "Image size, WIDTHxHEIGHT")->capture_default_str();
    sub->add_option("--eye", o->eye, "Camera position x,y,z (default: frame the scene)")->delimiter(',')->expected(3);
    sub->add_option("--target", o->target, "Point looked at x,y,z (default: the scene's centre)")->delimiter(',')->expected(3);
    sub->add_option("--up", o->up, "Up direction x,y,z")->delimiter(',')->expected(3)->capture_default_str();
    sub->add_option("--fov", o->fov, "Vertical field of view, degrees")->check(CLI::Range(1.0, 170.0))->capture_default_str();
    sub->add_flag("--ortho", o->orthographic,
                  "Orthographic projection (elevations, orthophotos): framed to the scene. Looking straight down on "
                  "georeferenced models, also writes a world file and a .prj beside the image");
    sub->add_flag("--top", o->top, "A map: orthographic, straight down, north up, framed to the scene (with a world file and .prj)")
        ->excludes("--eye");
    sub->add_option("--pixel-error", o->scene.pixel_error, "Pixels an HLOD cube's error bound may span at its nearest point (the finest level is exempt)")
        ->check(positive_number())->capture_default_str();
    sub->add_option("--channels", o->channels, "EXR channels: RGBA, Z (eye-space depth), N (world normals), level, id")
        ->capture_default_str();
    sub->add_option("--compression", o->compression, "EXR compression: none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa, dwab")
        ->capture_default_str();
    sub->add_option("--samples", o->samples, "Multisampling: 1, 2, 4 or 8 samples per pixel")->check(CLI::IsMember({1, 2, 4, 8}))
        ->capture_default_str();
    sub->add_option("--background", o->background, "Background colour r,g,b,a (linear)")->delimiter(',')->expected(4);
    sub->add_option("--debug", o->scene.debug_view, "HLOD debug view: none, levels (colour by level), wireframe, residency (stand-ins for cubes still loading in orange)")
        ->check(CLI::IsMember({"none", "levels", "wireframe", "residency"}))->capture_default_str();
    sub->add_flag("--boxes", o->scene.cube_boxes, "Outline the HLOD cubes drawn, coloured by level");
    sub->add_flag("--no-morph", o->no_morph, "Draw HLOD cubes without morphing toward their parents (shows cracks)");
    add_memory_options(*sub, o->memory);
    sub->add_flag("-q,--quiet", o->quiet, "Print nothing on success");
    return {sub, [o] { return run_render(*o); }};
}

}  // namespace strata::cli
