// The scene graph's nodes (OpenSceneGraph's ideas, lighter): Node, Group, Transform. Node types
// that draw derive from Drawable (drawable.h); cameras and lights live in camera.h and light.h.
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include <glm/glm.hpp>

#include "engine/scene/bounds.h"

namespace strata {

class NodeVisitor;
class Group;

// A value a user (or a script) hangs on a node: a number, a string or a flag.
using UserValue = std::variant<double, std::string, bool>;

class Node {
public:
    Node();
    virtual ~Node() = default;
    Node(const Node&) = delete;
    Node& operator=(const Node&) = delete;

    // Double dispatch: calls visitor.apply(*this) with the most derived type the visitor knows.
    virtual void accept(NodeVisitor& visitor);

    const std::string& name() const { return name_; }
    void set_name(std::string name) { name_ = std::move(name); }

    // Unique for the process; 0 is never used (it means "background" in the node-id image channel).
    uint32_t id() const { return id_; }

    // A visitor enters a node when (mask & its traversal mask) != 0; mask 0 hides the node.
    uint32_t mask() const { return mask_; }
    void set_mask(uint32_t mask) { mask_ = mask; }
    bool visible() const { return mask_ != 0; }
    void set_visible(bool visible) { mask_ = visible ? ~0u : 0u; }

    const UserValue* user_value(const std::string& key) const;
    void set_user_value(const std::string& key, UserValue value) { user_values_[key] = std::move(value); }
    const std::map<std::string, UserValue>& user_values() const { return user_values_; }

    // The box around everything below this node, in this node's parent frame; cached until a change
    // below calls dirty_bound().
    const Box& bound() const;
    void dirty_bound();

    const std::vector<Group*>& parents() const { return parents_; }

    // Expires when the node is destroyed: caches keyed by node (GPU resources) watch it.
    std::weak_ptr<const void> lifetime() const {
        if (!alive_) alive_ = std::make_shared<char>();
        return alive_;
    }

protected:
    // From the children's cached bounds: bound() brings those up to date first.
    virtual Box compute_bound() const { return {}; }

private:
    friend class Group;
    friend class NodeVisitor;
    // Hands the children, if any, to the visitor's stack (NodeVisitor::traverse visits them).
    virtual void traverse(NodeVisitor&) {}
    // Recomputes the dirty bounds at and below this node, children before parents.
    void refresh_bounds() const;

    std::string name_;
    uint32_t id_;
    uint32_t mask_ = ~0u;
    std::map<std::string, UserValue> user_values_;
    std::vector<Group*> parents_;
    mutable Box bound_;
    mutable bool bound_dirty_ = true;
    mutable std::shared_ptr<char> alive_;  // made on the first lifetime() call
};

using NodePtr = std::shared_ptr<Node>;

// Deep graphs (a chain of 200 000 groups) are fine: adding, bounds, visitors, find and destruction
// walk them with explicit stacks, not recursion.
class Group : public Node {
public:
    ~Group() override;
    void accept(NodeVisitor& visitor) override;

    void add(NodePtr child);
    // False when `child` is not a child of this group.
    bool remove(const Node* child);
    void clear();
    size_t child_count() const { return children_.size(); }
    const NodePtr& child(size_t index) const { return children_.at(index); }
    const std::vector<NodePtr>& children() const { return children_; }

protected:
    Box compute_bound() const override;
    // Hands every child to the visitor, in order; a group that shows its children only at times
    // (nodes/terrain.h) overrides it.
    void traverse(NodeVisitor& visitor) override;

private:
    // Whether adding `child` here would make a cycle: it is this group or one of its ancestors.
    bool would_contain_itself(const Node& child) const;

    std::vector<NodePtr> children_;
};

// A group whose children live in a frame placed by `matrix` (child frame → parent frame). The HLOD
// selection assumes uniform scale (DESIGN.md §3).
class Transform : public Group {
public:
    void accept(NodeVisitor& visitor) override;

    const glm::dmat4& matrix() const { return matrix_; }
    void set_matrix(const glm::dmat4& matrix);

protected:
    Box compute_bound() const override;

private:
    glm::dmat4 matrix_{1.0};
};

// A rotation times a uniform scale and a translation (no shear, mirror, stretch or projection), to a
// relative 1e-9: what translate / rotate / scale fields can show and rebuild without changing it.
bool is_rotation_and_uniform_scale(const glm::dmat4& matrix);

// The first node named `name` at or below `root`, depth first; nullptr if none.
Node* find_node(Node& root, const std::string& name);
// The same, sharing ownership of what it finds.
NodePtr find_node(const NodePtr& root, const std::string& name);
// The shared pointer that holds `node` at or below `root` (a pick names its node by address, a
// script or the editor needs a handle that keeps it alive); nullptr if it is not there.
NodePtr find_node(const NodePtr& root, const Node* node);

}  // namespace strata
