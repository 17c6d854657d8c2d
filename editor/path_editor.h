// The path editor: keyframes taken from the camera (add, move to the current view, remove), a duration
// per segment (or automatic: constant speed), a timeline to scrub and play, the path drawn over the
// scene, JSON save and load (engine/path).
#pragma once

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "engine/path/camera_path.h"
#include "engine/scene/camera.h"

struct ImDrawList;

namespace strata {

class PathEditor {
public:
    explicit PathEditor(Camera& camera) : camera_(camera) {}

    // A key at the camera's pose, after the key the timeline is at (or at the end).
    void add_key();
    void move_key(size_t key);  // to the camera's pose
    void remove_key(size_t key);
    // Seconds from `key` to the next; nullopt: automatic (time in proportion to length).
    void set_duration(size_t key, std::optional<double> seconds);
    const std::vector<Keyframe>& keys() const { return keys_; }
    // Replaces the keys (a path loaded from a scene script).
    void set_path(const CameraPath& path);

    // The path, once it has two keys that make one; else nullptr, and error() says why.
    const CameraPath* path() const { return path_ ? &*path_ : nullptr; }
    const std::string& error() const { return error_; }

    double time() const { return time_; }
    // Puts the camera where the path is at `seconds` (clamped to the path).
    void scrub(double seconds);
    // The playing time runs on the wall clock from this call: not from the last frame drawn, which a
    // script may have drawn long before it pressed Play.
    void play(bool on);
    bool playing() const { return playing_; }
    // While playing: moves the time on by the wall-clock time since Play or the last advance, and the
    // camera with it; stops at the end.
    void advance();

    // Throws std::runtime_error naming the file (and the key at fault for a bad file).
    void save(const std::filesystem::path& file) const;
    void load(const std::filesystem::path& file);

    void draw_panel();
    // The path as a line through the scene, its keys as dots (the current one highlighted).
    void draw_overlay(ImDrawList& list, float width, float height) const;

private:
    void rebuild();
    size_t key_at_time() const;

    Camera& camera_;
    std::vector<Keyframe> keys_;
    PathOptions options_;
    std::optional<CameraPath> path_;
    std::string error_;
    double time_ = 0;
    bool playing_ = false;
    std::chrono::steady_clock::time_point last_advance_;
    std::string file_ = "path.json";
    std::string file_message_;
};

}  // namespace strata
