// A terrain with meshes embedded in it (thesis 003; preprocess/HYBRID.md): the ground's HLOD model and,
// per embedding, the skirt that joins the ground to the site, the site under its placement, and the
// seams that weld the three per view (nodes/embedding_stitch.h). Where a view draws the ground over an
// embedding's zone at the embedding's level m or finer, the ground hides the zone's cells and the
// embedding is drawn; elsewhere the ground covers the zone as it is and the embedding is not drawn.
//
//   Terrain ─┬─ HlodModel (the ground)
//            └─ Embedding ─┬─ HlodModel (the skirt, in the ground's frame)
//                          ├─ Transform (the placement) ── HlodModel (the site)
//                          └─ EmbeddingSeams
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "engine/scene/drawable.h"
#include "engine/scene/node.h"
#include "nodes/embedding_stitch.h"
#include "nodes/hlod_model.h"
#include "preprocess/embedding_file.h"

namespace strata {

class EmbeddingSeams;

// One embedding: a group whose children visitors see only while the view the terrain was last culled
// or picked for draws it.
class Embedding : public Group {
public:
    Embedding(EmbeddedModels models, const std::string& name);
    ~Embedding() override;
    const EmbeddingStitch& stitch() const { return stitch_; }
    const std::shared_ptr<HlodModel>& skirt() const { return skirt_; }
    const std::shared_ptr<HlodModel>& site() const { return site_; }
    const std::shared_ptr<Transform>& placement() const { return placement_; }
    EmbeddingSeams& seams() const { return *seams_; }
    // Whether the last view drew it.
    bool drawn() const { return drawn_; }

    // What one view selected of a model, and the κ it morphs with.
    struct Selection {
        std::vector<uint32_t> cubes;
        Kappas kappa;
    };
    // What the view being culled selected of the ground, the skirt and the site (kappa null until it has).
    struct ViewSelections {
        Selection terrain, skirt, site;
    };
    const ViewSelections& selections() const { return selections_; }

protected:
    void traverse(NodeVisitor& visitor) override;

private:
    friend class Terrain;
    // A new view: nothing selected yet, not drawn.
    void begin_view();
    // The ground's selection for the view: whether it draws the embedding; the cubes' runs it hides.
    void take_ground_selection(std::span<const uint32_t> cubes, const Kappas& kappa, HlodModel::CubeRuns& hidden);

    EmbeddingStitch stitch_;
    std::shared_ptr<HlodModel> skirt_, site_;
    std::shared_ptr<Transform> placement_;
    std::shared_ptr<EmbeddingSeams> seams_;
    ViewSelections selections_;
    bool drawn_ = false;
};

// The seams of an embedding, drawn from the selections its models made for the view (the CPU twin
// emits them; each vertex drawn through its owner's transform and anchor, as its owner draws it).
class EmbeddingSeams : public Drawable {
public:
    explicit EmbeddingSeams(const Embedding& embedding) : embedding_(embedding) {}
    void cull(CullVisitor& cull) override;
    // The seams' vertices morphed on the GPU by their owners (a compute pass), which draw() draws.
    void prepare(DrawContext& context, const DrawItem& item) override;
    void draw(DrawContext& context, const DrawItem& item) override;
    // Verification of the GPU pass: while on, each draw copies back the seams' vertices as the owners'
    // morph wrote them (xyz from the owner's anchor, w the owner), in EmbeddingStitch::seam_vertices' order.
    void set_capture(bool on) { capture_ = on; }
    const std::vector<glm::vec4>& captured() const { return captured_; }

protected:
    Box compute_bound() const override;

private:
    const Embedding& embedding_;  // its parent, which owns it
    bool capture_ = false;
    std::vector<glm::vec4> captured_;
};

class Terrain : public Group {
public:
    explicit Terrain(std::shared_ptr<HlodModel> ground);
    ~Terrain() override;
    const std::shared_ptr<HlodModel>& ground() const { return ground_; }

    // Embeds `site`, placed by `site_to_terrain` (its node frame to the ground's), joined by `skirt` over
    // the zone the embedding's preprocessing chose (drawn from level `drawn_from`, `zone` its covers at
    // the level before). Throws std::runtime_error naming `name` when they do not fit together, or when
    // its zone shares a cell with another embedding's (zones that only touch are fine).
    std::shared_ptr<Embedding> embed(std::shared_ptr<HlodModel> skirt, std::shared_ptr<HlodModel> site, const glm::dmat4& site_to_terrain,
                                     uint32_t drawn_from, CellCovers zone, const std::string& name);
    // Loads an embedding file (preprocess/embedding_file.h: what `strata embed` writes): its skirt and
    // the site it names, both streamed, checked to be the models it was made for. A standing site (a
    // closed mesh) comes back as its placement's Transform, which the terrain simply holds. Throws
    // std::runtime_error naming the files.
    NodePtr load_embedding(const std::filesystem::path& file);
    // Where a child loaded from an embedding file stands, as `at`, scale and heading (placement_of): where
    // an editor moving it starts. Throws std::runtime_error naming the file, or saying the node has none.
    SitePlacement placement(const Node* child) const;
    // Moves a child loaded from an embedding file: the file made again for `placement` (the same path),
    // and reloaded in the child's stead; the new node. Throws std::runtime_error naming the files when the
    // new placement cannot be embedded (off the raster, its zone over another's, …): the child and its
    // file then stay as they were. It is remake_for(child), build_embedding, then replace_embedding: a
    // caller that builds on another thread (an editor, with progress) takes those steps itself.
    NodePtr move_embedding(const Node* child, const SitePlacement& placement, const Progress& progress = {});
    // What building a child's embedding file again reads and writes: the ground's and the site's files,
    // and `remade`, beside the child's file, which replace_embedding then puts in its place.
    struct Remake {
        std::filesystem::path terrain, site, remade;
    };
    Remake remake_for(const Node* child) const;
    // The child reloaded from `remade` (remake_for's, made): that file takes the child's file's name and
    // the new node the child's place. When it cannot be loaded, the child and its file stay as they were
    // (std::runtime_error naming the files). `remade` is gone in either case.
    NodePtr replace_embedding(const Node* child, const std::filesystem::path& remade);
    // The embeddings and standing sites it holds.
    bool remove_embedding(const Node* embedding);
    std::vector<std::shared_ptr<Embedding>> embeddings() const;
    // The file a child embedding (or standing site) was loaded from; null for one made in code, or a
    // node no longer its child (removed by a path other than remove_embedding).
    const std::filesystem::path* embedding_file(const Node* child) const;

protected:
    void traverse(NodeVisitor& visitor) override;

private:
    // embedding_file, or std::runtime_error naming the node when it has none.
    const std::filesystem::path& loaded_file(const Node* child) const;
    std::shared_ptr<const HlodModel::CubeRuns> take_ground_selection(std::span<const uint32_t> cubes, const Kappas& kappa);
    std::shared_ptr<HlodModel> ground_;
    std::map<const Node*, std::filesystem::path> files_;
};

}  // namespace strata
