#include "editor/path_editor.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include <imgui.h>
#include <imgui_stdlib.h>

#include "editor/widgets.h"

namespace strata {

namespace {

Keyframe key_from(const Camera& camera) {
    Keyframe key;
    key.position = camera.position;
    key.orientation = camera.orientation;
    key.fov_degrees = camera.fov_y_degrees;
    return key;
}

// Where a point of the world lands in a width × height window (y down), or nothing behind the eye.
std::optional<ImVec2> project(const Camera& camera, const glm::dvec3& point, float width, float height) {
    const glm::dvec4 clip = camera.projection_matrix(1e-3, 1e3) * camera.view_matrix() * glm::dvec4(point, 1.0);
    if (clip.w <= 1e-9) return std::nullopt;
    return ImVec2(float((clip.x / clip.w * 0.5 + 0.5) * width), float((0.5 - clip.y / clip.w * 0.5) * height));
}

}  // namespace

void PathEditor::rebuild() {
    path_.reset();
    error_.clear();
    if (keys_.size() < 2) {
        error_ = keys_.empty() ? "no keys yet" : "one key: add another";
    } else {
        try {
            path_ = CameraPath::from_keys(keys_, options_);
        } catch (const std::exception& e) {
            error_ = e.what();
        }
    }
    if (!path_) playing_ = false;
    time_ = path_ ? std::min(time_, path_->duration()) : 0;
}

size_t PathEditor::key_at_time() const {
    if (!path_) return keys_.empty() ? 0 : keys_.size() - 1;
    size_t key = 0;
    while (key + 1 < keys_.size() && path_->key_time(key + 1) <= time_ + 1e-9) ++key;
    return key;
}

void PathEditor::add_key() {
    const bool at_end = !path_ || time_ >= path_->duration() - 1e-9;
    const size_t position = at_end ? keys_.size() : key_at_time() + 1;
    keys_.insert(keys_.begin() + std::ptrdiff_t(position), key_from(camera_));
    if (keys_.back().duration) keys_.back().duration.reset();  // the last key has no segment
    rebuild();
    if (path_) time_ = path_->key_time(position);
}

void PathEditor::move_key(size_t key) {
    const std::optional<double> duration = keys_.at(key).duration;
    keys_[key] = key_from(camera_);
    keys_[key].duration = duration;
    rebuild();
}

void PathEditor::remove_key(size_t key) {
    keys_.erase(keys_.begin() + std::ptrdiff_t(key));
    if (!keys_.empty()) keys_.back().duration.reset();
    rebuild();
}

void PathEditor::set_duration(size_t key, std::optional<double> seconds) {
    if (key + 1 >= keys_.size()) throw std::out_of_range("the last key has no segment after it");
    keys_.at(key).duration = seconds;
    rebuild();
}

void PathEditor::set_path(const CameraPath& path) {
    keys_ = path.keys();
    options_ = path.options();
    time_ = 0;
    rebuild();
}

void PathEditor::scrub(double seconds) {
    if (!path_) return;
    time_ = std::clamp(seconds, 0.0, path_->duration());
    const Pose pose = path_->sample(time_);
    camera_.position = pose.position;
    camera_.orientation = pose.orientation;
    camera_.fov_y_degrees = pose.fov_degrees;
}

void PathEditor::play(bool on) {
    playing_ = on && path_;
    last_advance_ = std::chrono::steady_clock::now();
}

void PathEditor::advance() {
    if (!playing_ || !path_) return;
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - last_advance_).count();
    last_advance_ = now;
    scrub(time_ + seconds);
    if (time_ >= path_->duration()) playing_ = false;
}

void PathEditor::save(const std::filesystem::path& file) const {
    if (!path_) throw std::runtime_error("cannot save " + file.string() + ": the path is not complete (" + error_ + ")");
    path_->save(file);
}

void PathEditor::load(const std::filesystem::path& file) { set_path(CameraPath::load(file)); }

void PathEditor::draw_panel() {
    if (ImGui::Button("Add key at camera")) add_key();
    ImGui::SameLine();
    ImGui::BeginDisabled(!path_);
    if (ImGui::Button(playing_ ? "Pause" : "Play")) {
        if (!playing_ && path_ && time_ >= path_->duration()) time_ = 0;
        play(!playing_);
    }
    ImGui::EndDisabled();
    if (path_) {
        float t = float(time_);
        ImGui::SetNextItemWidth(-1);
        if (ImGui::SliderFloat("##timeline", &t, 0.0f, float(path_->duration()), "%.2f s")) {
            playing_ = false;
            scrub(t);
        }
    } else {
        ImGui::TextDisabled("%s", error_.c_str());
    }
    ImGui::TextDisabled("segment time 0 = automatic (constant speed)");
    if (ImGui::BeginTable("keys", 4, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingFixedFit)) {
        ImGui::TableSetupColumn("key");
        ImGui::TableSetupColumn("at");
        ImGui::TableSetupColumn("next (s)");
        ImGui::TableSetupColumn("");
        ImGui::TableHeadersRow();
        std::optional<size_t> removed;
        for (size_t i = 0; i < keys_.size(); ++i) {
            ImGui::PushID(int(i));
            ImGui::TableNextRow();
            ImGui::TableNextColumn();
            if (ImGui::Selectable(std::to_string(i).c_str(), path_ && key_at_time() == i)) scrub(path_ ? path_->key_time(i) : 0);
            ImGui::TableNextColumn();
            if (path_) ImGui::Text("%.2f s", path_->key_time(i));
            ImGui::TableNextColumn();
            if (i + 1 < keys_.size()) {
                float seconds = float(keys_[i].duration.value_or(0.0));
                ImGui::SetNextItemWidth(60);
                // Applied as typed, like the inspector's fields: clicking away keeps what was typed.
                if (ImGui::InputFloat("##duration", &seconds, 0, 0, "%.2f"))
                    set_duration(i, seconds > 0 ? std::optional<double>(seconds) : std::nullopt);
            }
            ImGui::TableNextColumn();
            if (ImGui::SmallButton("Set")) move_key(i);
            ImGui::SameLine();
            if (ImGui::SmallButton("x")) removed = i;
            ImGui::PopID();
        }
        ImGui::EndTable();
        if (removed) remove_key(*removed);
    }
    if (ImGui::Button("Save")) file_message_ = outcome([&] { save(file_); }, "saved " + file_);
    ImGui::SameLine();
    if (file_field("path file", "path.json", file_, "Load")) file_message_ = outcome([&] { load(file_); }, "loaded " + file_);
    if (!file_message_.empty()) ImGui::TextWrapped("%s", file_message_.c_str());
}

void PathEditor::draw_overlay(ImDrawList& list, float width, float height) const {
    const ImU32 line = IM_COL32(255, 200, 60, 220), dot = IM_COL32(255, 255, 255, 255), current = IM_COL32(255, 90, 60, 255);
    if (path_) {
        // Enough samples that a curve looks smooth; segments behind the eye are left out.
        const int samples = 64 * int(keys_.size());
        std::optional<ImVec2> previous;
        for (int i = 0; i <= samples; ++i) {
            const std::optional<ImVec2> point = project(camera_, path_->sample(path_->duration() * i / samples).position, width, height);
            if (point && previous) list.AddLine(*previous, *point, line, 2.0f);
            previous = point;
        }
    }
    const size_t now = key_at_time();
    for (size_t i = 0; i < keys_.size(); ++i)
        if (const auto point = project(camera_, keys_[i].position, width, height))
            list.AddCircleFilled(*point, 5.0f, i == now && path_ ? current : dot);
}

}  // namespace strata
