// The editor's part for embeddings (issue 18 §2): with a terrain selected (or its ground: what a click
// on it selects), a form that embeds a site in it, at the cursor's point on the ground or where typed;
// with one of its embeddings (or standing sites) selected, or a node inside one, that embedding's
// placement, to move it, and a button that removes it. Each action is the terrain's own
// (Terrain::load_embedding, move_embedding, remove_embedding), as scripts have them; the files of Embed
// and Move are made on a worker thread (EmbeddingJob), the window live, with their progress shown.
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <glm/glm.hpp>

#include "editor/embedding_job.h"
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

// Where a new embedding of `site` in `terrain` goes: "<site>_on_<terrain>.hlod" beside the site,
// numbered ("…_2.hlod") when the terrain holds that file already, so that two embeddings of one site do
// not share a file.
std::filesystem::path new_embedding_file(const Terrain& terrain, const std::filesystem::path& site);

class EmbeddingPanel {
public:
    EmbeddingPanel() = default;
    ~EmbeddingPanel() { cancel_job(); }
    EmbeddingPanel(const EmbeddingPanel&) = delete;
    EmbeddingPanel& operator=(const EmbeddingPanel&) = delete;
    // Draws the part for `selected` (nothing for a node outside every terrain); while an embedding is
    // being made, its progress and a Cancel button instead, whatever is selected. After an action, the
    // node to select (null: none).
    std::optional<NodePtr> draw(const Group& scene, const NodePtr& selected, const std::optional<glm::dvec3>& cursor);
    // Once a frame, panel drawn or not: when a job started from the panel is done, its node, put in
    // its terrain (to select); its failure is the panel's message.
    std::optional<NodePtr> poll();

    // Start making an embedding on a worker thread (EmbeddingJob): `site` embedded in `terrain`, or
    // `embedding`, a child of `terrain`, moved. `awaited`: the caller takes the result itself
    // (finish_job) rather than poll(). Throws when a job runs already, before any work.
    void start_embed(Terrain& terrain, const std::filesystem::path& site, const SitePlacement& placement, bool awaited);
    void start_move(const NodePtr& embedding, Terrain& terrain, const SitePlacement& placement, bool awaited);
    bool job_running() const { return running_.has_value(); }
    bool job_finished() const { return running_ && running_->job->finished(); }
    void wait_job() { running_->job->wait(); }
    // Cancels the job, waits for it and drops what it made.
    void cancel_job();
    // The finished job's node, put in its terrain on this (the UI) thread. Rethrows its failure
    // (Cancelled when cancelled); throws when its terrain or embedding left the scene meanwhile.
    NodePtr finish_job();

private:
    // A job and what puts its file in the scene: `anchor` (the terrain, or a node in it) must still lie
    // in `terrain` then.
    struct Running {
        std::unique_ptr<EmbeddingJob> job;
        NodePtr anchor;
        const Terrain* terrain;
        std::function<NodePtr(Terrain&)> apply;
        std::function<void()> discard;  // what the job made that no node will take
        bool awaited;
    };
    void check_idle() const;
    void draw_job();
    std::optional<NodePtr> draw_embed_form(const Group& scene, Terrain& terrain, const std::optional<glm::dvec3>& cursor);
    std::optional<NodePtr> draw_placement_form(const Group& scene, Terrain& terrain, const NodePtr& child, const std::optional<glm::dvec3>& cursor);
    // lon, lat, scale and heading fields, and a button that puts the cursor's place in lon and lat.
    void draw_placement_fields(const Group& scene, const Terrain& terrain, const std::optional<glm::dvec3>& cursor);
    SitePlacement placement() const;

    std::optional<Running> running_;
    const Node* filled_for_ = nullptr;  // the node the fields were last filled for
    std::string site_;
    std::array<double, 2> at_{};
    double scale_ = 1, heading_ = 0;
    bool tilted_ = false;  // the embedding shown was placed by a matrix these fields cannot give
    std::string message_;
};

}  // namespace strata
