#include "editor/embedding_panel.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

#include <imgui.h>
#include <imgui_stdlib.h>

#include "editor/geo_readout.h"
#include "editor/widgets.h"
#include "nodes/terrain.h"
#include "preprocess/georeference.h"

namespace strata {

namespace fs = std::filesystem;

std::optional<TerrainPart> terrain_part(const NodePtr& node) {
    const Node* below = nullptr;  // the node met just before, going up
    for (Node* at = node.get(); at; at = at->parents().empty() ? nullptr : at->parents().front()) {
        if (auto* terrain = dynamic_cast<Terrain*>(at)) {
            const auto child = std::find_if(terrain->children().begin(), terrain->children().end(), [&](const NodePtr& c) { return c.get() == below; });
            return TerrainPart{terrain, child == terrain->children().end() ? nullptr : *child};
        }
        below = at;
    }
    return std::nullopt;
}

std::array<double, 2> default_site_place(const Group& scene, const Terrain& terrain, const std::optional<glm::dvec3>& cursor) {
    if (cursor) {
        GeoReadout ground;
        ground.update(scene, terrain.ground().get());
        if (const std::optional<GeoReading> reading = ground.read(*cursor)) return {reading->geo[0], reading->geo[1]};
    }
    const glm::dvec3 middle = terrain.ground()->bound().center();  // the ground's frame is the terrain's
    const std::array<double, 3> geo = terrain.ground()->georeference()->to_geo({middle.x, middle.y, middle.z});
    return {geo[0], geo[1]};
}

fs::path new_embedding_file(const Terrain& terrain, const fs::path& site) {
    for (int n = 1;; ++n) {
        const fs::path candidate = default_embedding_file(terrain.ground()->path(), site, n);
        const bool held = std::any_of(terrain.children().begin(), terrain.children().end(), [&](const NodePtr& child) {
            const fs::path* file = terrain.embedding_file(child.get());
            return file && fs::weakly_canonical(*file) == fs::weakly_canonical(candidate);
        });
        if (!held) return candidate;
    }
}

void EmbeddingPanel::cancel_job() {
    if (!running_) return;
    running_->job->cancel();
    running_->job->wait();
    running_->discard();
    running_.reset();
}

void EmbeddingPanel::check_idle() const {
    if (running_) throw std::runtime_error("an embedding is being made (" + running_->job->title() + "): wait for it, or cancel it");
}

void EmbeddingPanel::start_embed(Terrain& terrain, const fs::path& site, const SitePlacement& placement, bool awaited) {
    check_idle();  // before the job's thread starts
    const fs::path ground = terrain.ground()->path(), output = new_embedding_file(terrain, site);
    auto made = std::make_shared<fs::path>();  // the file, once made
    // The ground stands for its terrain: it lies in it as long as the terrain is in the scene.
    running_ = Running{std::make_unique<EmbeddingJob>("embedding " + site.filename().string(),
                                                      [=](const Progress& progress) { *made = embedding_file_for(ground, site, placement, output, progress); }),
                       terrain.ground(), &terrain, [made](Terrain& t) { return t.load_embedding(*made); },
                       [] {},  // the file stays: a complete embedding, reused if asked again
                       awaited};
}

void EmbeddingPanel::start_move(const NodePtr& embedding, Terrain& terrain, const SitePlacement& placement, bool awaited) {
    check_idle();
    const Terrain::Remake remake = terrain.remake_for(embedding.get());
    EmbedSettings settings;
    settings.placement = placement;
    running_ = Running{
        std::make_unique<EmbeddingJob>("moving " + embedding->name(),
                                       [=](const Progress& progress) { build_embedding(remake.terrain, remake.site, remake.remade, settings, progress); }),
        embedding, &terrain, [embedding, remade = remake.remade](Terrain& t) { return t.replace_embedding(embedding.get(), remade); },
        [remade = remake.remade] {
            std::error_code ignored;
            fs::remove(remade, ignored);
        },
        awaited};
}

NodePtr EmbeddingPanel::finish_job() {
    Running running = std::move(*running_);
    running_.reset();
    running.job->wait();
    running.job->rethrow();
    const std::optional<TerrainPart> part = terrain_part(running.anchor);
    if (!part || part->terrain != running.terrain) {
        running.discard();
        throw std::runtime_error(running.job->title() + ": its terrain, or the embedding, left the scene meanwhile");
    }
    return running.apply(*part->terrain);
}

std::optional<NodePtr> EmbeddingPanel::poll() {
    if (!running_ || running_->awaited || !running_->job->finished()) return std::nullopt;
    const std::string title = running_->job->title();
    try {
        NodePtr next = finish_job();
        filled_for_ = nullptr;  // the new node's own placement is shown next
        message_.clear();
        return next;
    } catch (const Cancelled&) {
        message_ = title + ": cancelled, nothing changed";
    } catch (const std::exception& e) {
        message_ = e.what();
    }
    return std::nullopt;
}

void EmbeddingPanel::draw_job() {
    const EmbeddingJob::Status status = running_->job->status();
    ImGui::TextUnformatted(running_->job->title().c_str());
    char overlay[96];
    std::snprintf(overlay, sizeof overlay, "%s %.0f %%, %.0f s", status.stage.c_str(), 100 * std::max(status.fraction, 0.0), status.seconds);
    ImGui::ProgressBar(status.fraction < 0 ? float(-0.3 * ImGui::GetTime()) : float(status.fraction), ImVec2(-1, 0), overlay);
    if (ImGui::Button("Cancel")) running_->job->cancel();
}

std::optional<NodePtr> EmbeddingPanel::draw(const Group& scene, const NodePtr& selected, const std::optional<glm::dvec3>& cursor) {
    if (running_) {
        ImGui::Separator();
        draw_job();
        return std::nullopt;
    }
    const std::optional<TerrainPart> part = terrain_part(selected);
    if (!part) return std::nullopt;
    ImGui::Separator();
    if (!part->child || part->child == part->terrain->ground()) return draw_embed_form(scene, *part->terrain, cursor);
    if (!part->terrain->embedding_file(part->child.get())) {
        ImGui::TextDisabled("an embedding made by a script without a file: move it from the script");
        return std::nullopt;
    }
    return draw_placement_form(scene, *part->terrain, part->child, cursor);
}

std::optional<NodePtr> EmbeddingPanel::draw_embed_form(const Group& scene, Terrain& terrain, const std::optional<glm::dvec3>& cursor) {
    if (filled_for_ != &terrain) {
        filled_for_ = &terrain;
        at_ = default_site_place(scene, terrain, cursor);
        scale_ = 1, heading_ = 0;
        message_.clear();
    }
    ImGui::TextDisabled("embed a site in %s", terrain.name().c_str());
    draw_placement_fields(scene, terrain, cursor);
    if (file_field("site", ".hlod built with --lock-boundary, or a mesh", site_, "Embed"))
        message_ = outcome([&] { start_embed(terrain, site_, placement(), false); }, "");
    if (!message_.empty()) ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.4f, 1.0f), "%s", message_.c_str());
    return std::nullopt;
}

std::optional<NodePtr> EmbeddingPanel::draw_placement_form(const Group& scene, Terrain& terrain, const NodePtr& child,
                                                           const std::optional<glm::dvec3>& cursor) {
    if (filled_for_ != child.get()) {
        filled_for_ = child.get();
        message_ = outcome(
            [&] {
                const SitePlacement now = terrain.placement(child.get());
                at_ = *now.at, scale_ = now.scale, heading_ = now.heading;
                const glm::dmat4& m = *now.matrix;  // its up axis off the vertical, or tipped: a tilt
                tilted_ = std::max({std::abs(m[2][0]), std::abs(m[2][1]), std::abs(m[0][2]), std::abs(m[1][2])}) > 1e-9 * now.scale;
            },
            "");
    }
    ImGui::TextDisabled("%s embedded in %s", child->name().c_str(), terrain.name().c_str());
    if (tilted_) ImGui::TextDisabled("placed by a tilted matrix: Move sets it level, by these fields");
    draw_placement_fields(scene, terrain, cursor);
    std::optional<NodePtr> next;
    if (ImGui::Button("Move")) message_ = outcome([&] { start_move(child, terrain, placement(), false); }, "");
    ImGui::SameLine();
    if (ImGui::Button("Remove") && terrain.remove_embedding(child.get())) next = NodePtr();
    if (next) filled_for_ = nullptr;
    if (!message_.empty()) ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.4f, 1.0f), "%s", message_.c_str());
    return next;
}

void EmbeddingPanel::draw_placement_fields(const Group& scene, const Terrain& terrain, const std::optional<glm::dvec3>& cursor) {
    ImGui::InputDouble("longitude", &at_[0], 0, 0, "%.7f°");
    ImGui::InputDouble("latitude", &at_[1], 0, 0, "%.7f°");
    ImGui::BeginDisabled(!cursor);
    if (ImGui::Button("At the cursor")) at_ = default_site_place(scene, terrain, cursor);
    ImGui::EndDisabled();
    if (!cursor && ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) ImGui::SetTooltip("click the ground in the view first");
    ImGui::InputDouble("scale", &scale_, 0, 0, "%.4g");
    ImGui::InputDouble("heading", &heading_, 0, 0, "%.2f°");
}

SitePlacement EmbeddingPanel::placement() const {
    SitePlacement placement;
    placement.at = at_;
    placement.scale = scale_;
    placement.heading = heading_;
    return placement;
}

}  // namespace strata
