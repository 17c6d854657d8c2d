// The editor's part for embeddings (issue 18 §2): with a terrain selected (or its ground: what a click
// on it selects), a form that embeds a site in it, at the cursor's point on the ground or where typed;
// with one of its embeddings (or standing sites) selected, or a node inside one, that embedding's
// placement, to move it, and a button that removes it. Each action is the terrain's own
// (Terrain::load_embedding, move_embedding, remove_embedding), as scripts have them.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>

#include <glm/glm.hpp>

#include "engine/scene/node.h"
#include "preprocess/embedding_file.h"

namespace strata {

class Terrain;

// The terrain a node belongs to, and the terrain's child it is or lies below (the ground, an embedding,
// a standing site); nothing for a node outside every terrain.
struct TerrainPart {
    Terrain* terrain = nullptr;
    NodePtr child;  // null when the node is the terrain itself
};
std::optional<TerrainPart> terrain_part(const NodePtr& node);

// Where a new embedding goes by default: the `cursor`'s point (world frame) on the terrain's ground
// as {lon, lat} on its CRS's datum, else the middle of the ground.
std::array<double, 2> default_site_place(const Group& scene, const Terrain& terrain, const std::optional<glm::dvec3>& cursor);

// Embeds `site` in `terrain` as `placement` says, in a file of its own beside the site:
// "<site>_on_<terrain>.hlod", numbered ("…_2.hlod") when the terrain holds that file already, so that two
// embeddings of one site do not share a file. The new node. Throws naming the files.
NodePtr embed_site(Terrain& terrain, const std::filesystem::path& site, const SitePlacement& placement);

class EmbeddingPanel {
public:
    // Draws the part for `selected` (nothing for a node outside every terrain). After an action, the
    // node to select instead (null: none).
    std::optional<NodePtr> draw(const Group& scene, const NodePtr& selected, const std::optional<glm::dvec3>& cursor);

private:
    std::optional<NodePtr> draw_embed_form(const Group& scene, Terrain& terrain, const std::optional<glm::dvec3>& cursor);
    std::optional<NodePtr> draw_placement_form(const Group& scene, Terrain& terrain, const NodePtr& child, const std::optional<glm::dvec3>& cursor);
    // lon, lat, scale and heading fields, and a button that puts the cursor's place in lon and lat.
    void draw_placement_fields(const Group& scene, const Terrain& terrain, const std::optional<glm::dvec3>& cursor);
    SitePlacement placement() const;

    const Node* filled_for_ = nullptr;  // the node the fields were last filled for
    std::string site_;
    std::array<double, 2> at_{};
    double scale_ = 1, heading_ = 0;
    std::string message_;
};

}  // namespace strata
