#include "editor/embedding_panel.h"

#include <algorithm>
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

NodePtr embed_site(Terrain& terrain, const fs::path& site, const SitePlacement& placement) {
    fs::path output;
    for (int n = 1; output.empty(); ++n) {
        const fs::path candidate = default_embedding_file(terrain.ground()->path(), site, n);
        const bool held = std::any_of(terrain.children().begin(), terrain.children().end(), [&](const NodePtr& child) {
            const fs::path* file = terrain.embedding_file(child.get());
            return file && fs::weakly_canonical(*file) == fs::weakly_canonical(candidate);
        });
        if (!held) output = candidate;
    }
    return terrain.load_embedding(embedding_file_for(terrain.ground()->path(), site, placement, output));
}

std::optional<NodePtr> EmbeddingPanel::draw(const Group& scene, const NodePtr& selected, const std::optional<glm::dvec3>& cursor) {
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
    std::optional<NodePtr> next;
    if (file_field("site", ".hlod built with --lock-boundary", site_, "Embed"))
        message_ = outcome([&] { next = embed_site(terrain, site_, placement()); }, "");
    if (next) filled_for_ = nullptr;  // the new embedding's own placement is shown next
    if (!message_.empty()) ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.4f, 1.0f), "%s", message_.c_str());
    return next;
}

std::optional<NodePtr> EmbeddingPanel::draw_placement_form(const Group& scene, Terrain& terrain, const NodePtr& child,
                                                           const std::optional<glm::dvec3>& cursor) {
    if (filled_for_ != child.get()) {
        filled_for_ = child.get();
        message_ = outcome(
            [&] {
                const SitePlacement now = terrain.placement(child.get());
                at_ = *now.at, scale_ = now.scale, heading_ = now.heading;
            },
            "");
    }
    ImGui::TextDisabled("%s embedded in %s", child->name().c_str(), terrain.name().c_str());
    draw_placement_fields(scene, terrain, cursor);
    std::optional<NodePtr> next;
    if (ImGui::Button("Move")) message_ = outcome([&] { next = terrain.move_embedding(child.get(), placement()); }, "");
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
