// Headless contexts through EGL: Mesa's surfaceless platform, the device platform (NVIDIA without X),
// or the default display with a 1×1 pbuffer; the first that gives OpenGL 4.5 core wins.
#include <epoxy/egl.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "engine/gl/context.h"
#include "engine/gl/gl.h"

namespace strata::gl {
namespace {

std::string egl_error_name(EGLint error) {
    switch (error) {
        case EGL_SUCCESS: return "EGL_SUCCESS";
        case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
        case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
        case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
        case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
        case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
        case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
        case EGL_BAD_CURRENT_SURFACE: return "EGL_BAD_CURRENT_SURFACE";
        case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
        case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
        case EGL_BAD_NATIVE_PIXMAP: return "EGL_BAD_NATIVE_PIXMAP";
        case EGL_BAD_NATIVE_WINDOW: return "EGL_BAD_NATIVE_WINDOW";
        case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
        case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
        case EGL_CONTEXT_LOST: return "EGL_CONTEXT_LOST";
        case EGL_BAD_DEVICE_EXT: return "EGL_BAD_DEVICE_EXT";
    }
    return "EGL error " + std::to_string(error);
}

// "eglInitialize failed: EGL_NOT_INITIALIZED", with the error EGL recorded for the failed call.
[[noreturn]] void throw_egl_failure(const std::string& call) {
    throw GlError(call + " failed: " + egl_error_name(eglGetError()));
}

bool has_client_extension(const char* name) { return epoxy_has_egl_extension(EGL_NO_DISPLAY, name); }

// Initializes `display` (again: a no-op after the first time). Displays are never terminated: EGL has one
// per platform and device for the whole process, so eglTerminate would pull it from under every other
// user (another context, another library), and initializing again reloads the driver (tens of ms).
void initialize(EGLDisplay display) {
    EGLint major = 0, minor = 0;
    if (!eglInitialize(display, &major, &minor)) throw_egl_failure("eglInitialize");
}

class EglContext final : public Context {
public:
    EglContext(EGLDisplay display, std::string platform) : Context(std::move(platform)), display_(display) {}
    ~EglContext() override;

    // Initializes the display, creates a 4.5 core context (on a 1×1 pbuffer when `use_pbuffer`, or when
    // the display cannot make a context current without a surface) and makes it current. Throws GlError;
    // what was made so far is released by the destructor.
    void open(bool use_pbuffer);
    void make_current() override;

private:
    EGLConfig choose_config(bool use_pbuffer) const;
    void create_context();

    EGLDisplay display_;
    EGLConfig config_ = EGL_NO_CONFIG_KHR;
    EGLContext context_ = EGL_NO_CONTEXT;
    EGLSurface surface_ = EGL_NO_SURFACE;
};

EglContext::~EglContext() {
    if (context_ != EGL_NO_CONTEXT && eglGetCurrentContext() == context_)
        eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (surface_ != EGL_NO_SURFACE) eglDestroySurface(display_, surface_);
    if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
}

void EglContext::open(bool use_pbuffer) {
    if (display_ == EGL_NO_DISPLAY) throw_egl_failure("getting the display");
    initialize(display_);
    // eglCreateContext makes a context of the thread's bound API.
    if (!eglBindAPI(EGL_OPENGL_API)) throw_egl_failure("eglBindAPI(EGL_OPENGL_API)");
    use_pbuffer = use_pbuffer || !epoxy_has_egl_extension(display_, "EGL_KHR_surfaceless_context");
    const bool needs_config = use_pbuffer || !epoxy_has_egl_extension(display_, "EGL_KHR_no_config_context");
    if (needs_config) config_ = choose_config(use_pbuffer);
    create_context();
    if (use_pbuffer) {
        const EGLint size[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
        surface_ = eglCreatePbufferSurface(display_, config_, size);
        if (surface_ == EGL_NO_SURFACE) throw_egl_failure("eglCreatePbufferSurface");
    }
    make_current();
    finish_setup();
}

EGLConfig EglContext::choose_config(bool use_pbuffer) const {
    const EGLint attributes[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                 EGL_SURFACE_TYPE,    use_pbuffer ? EGL_PBUFFER_BIT : 0,
                                 EGL_NONE};
    EGLConfig config = nullptr;
    EGLint count = 0;
    if (!eglChooseConfig(display_, attributes, &config, 1, &count)) throw_egl_failure("eglChooseConfig");
    if (count == 0) throw GlError("eglChooseConfig found no OpenGL config");
    return config;
}

void EglContext::create_context() {
    std::vector<EGLint> attributes = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                                      EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT};
    if (gl_debug_requested())
        attributes.insert(attributes.end(), {EGL_CONTEXT_FLAGS_KHR, EGL_CONTEXT_OPENGL_DEBUG_BIT_KHR});
    attributes.push_back(EGL_NONE);
    context_ = eglCreateContext(display_, config_, EGL_NO_CONTEXT, attributes.data());
    if (context_ == EGL_NO_CONTEXT) throw_egl_failure("eglCreateContext(OpenGL 4.5 core)");
}

void EglContext::make_current() {
    // The bound API is per thread, and another thread may start with OpenGL ES bound.
    if (!eglBindAPI(EGL_OPENGL_API)) throw_egl_failure("eglBindAPI(EGL_OPENGL_API)");
    if (!eglMakeCurrent(display_, surface_, surface_, context_)) throw_egl_failure("eglMakeCurrent");
}

// --- the three platforms: each returns a current context or throws GlError saying why not ---

std::unique_ptr<Context> open_surfaceless() {
    if (!has_client_extension("EGL_EXT_platform_base") || !has_client_extension("EGL_MESA_platform_surfaceless"))
        throw GlError("EGL_EXT_platform_base or EGL_MESA_platform_surfaceless not supported");
    auto context = std::make_unique<EglContext>(
        eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr),
        "EGL surfaceless (Mesa)");
    context->open(false);
    return context;
}

std::string device_label(EGLDeviceEXT device, std::size_t index) {
    std::string label = "EGL device " + std::to_string(index);
    if (!has_client_extension("EGL_EXT_device_query")) return label;
    const char* extensions = eglQueryDeviceStringEXT(device, EGL_EXTENSIONS);
    if (extensions && std::string_view(extensions).find("EGL_EXT_device_drm") != std::string_view::npos)
        if (const char* file = eglQueryDeviceStringEXT(device, EGL_DRM_DEVICE_FILE_EXT))
            label += std::string(" (") + file + ")";
    return label;
}

std::vector<EGLDeviceEXT> query_devices() {
    EGLint count = 0;
    if (!eglQueryDevicesEXT(0, nullptr, &count)) throw_egl_failure("eglQueryDevicesEXT");
    std::vector<EGLDeviceEXT> devices(static_cast<std::size_t>(count));
    if (!eglQueryDevicesEXT(count, devices.data(), &count)) throw_egl_failure("eglQueryDevicesEXT");
    devices.resize(static_cast<std::size_t>(count));
    if (devices.empty()) throw GlError("eglQueryDevicesEXT found no device");
    return devices;
}

std::unique_ptr<Context> open_device() {
    if (!has_client_extension("EGL_EXT_platform_device") || !has_client_extension("EGL_EXT_device_enumeration"))
        throw GlError("EGL_EXT_platform_device or EGL_EXT_device_enumeration not supported");
    const std::vector<EGLDeviceEXT> devices = query_devices();
    std::string failures;
    for (std::size_t i = 0; i < devices.size(); ++i) {
        const std::string label = device_label(devices[i], i);
        try {
            auto context = std::make_unique<EglContext>(
                eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr), label);
            context->open(false);
            return context;
        } catch (const GlError& e) {
            failures += (failures.empty() ? "" : "; ") + label + ": " + e.what();
        }
    }
    throw GlError(failures);
}

std::unique_ptr<Context> open_default_display() {
    auto context = std::make_unique<EglContext>(eglGetDisplay(EGL_DEFAULT_DISPLAY), "EGL default display");
    context->open(true);
    return context;
}

struct Platform {
    const char* name;
    std::unique_ptr<Context> (*open)();
};
constexpr Platform platforms[] = {
    {"surfaceless", open_surfaceless}, {"device", open_device}, {"default", open_default_display}};

// All platforms in order, or the one STRATA_EGL_PLATFORM names.
std::vector<Platform> platforms_to_try() {
    const char* forced = std::getenv("STRATA_EGL_PLATFORM");
    if (!forced || !*forced) return {std::begin(platforms), std::end(platforms)};
    for (const Platform& platform : platforms)
        if (platform.name == std::string_view(forced)) return {platform};
    throw GlError(std::string("STRATA_EGL_PLATFORM=") + forced + ": expected surfaceless, device or default");
}

}  // namespace

std::unique_ptr<Context> create_headless_context() {
    if (!epoxy_has_egl()) throw GlError("no OpenGL context: the EGL library (libEGL.so.1) cannot be loaded");
    std::string failures;
    for (const Platform& platform : platforms_to_try()) {
        try {
            return platform.open();
        } catch (const GlError& e) {
            failures += std::string("\n  ") + platform.name + ": " + e.what();
        }
    }
    throw GlError("no OpenGL 4.5 core context through EGL; tried:" + failures);
}

}  // namespace strata::gl
