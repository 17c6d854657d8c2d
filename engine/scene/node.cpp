#include "engine/scene/node.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "engine/scene/visitor.h"

namespace strata {

namespace {
std::atomic<uint32_t> next_node_id{1};
}

Node::Node() : id_(next_node_id.fetch_add(1)) {}

void Node::accept(NodeVisitor& visitor) { visitor.apply(*this); }

const UserValue* Node::user_value(const std::string& key) const {
    auto it = user_values_.find(key);
    return it == user_values_.end() ? nullptr : &it->second;
}

const Box& Node::bound() const {
    if (bound_dirty_) {
        bound_ = compute_bound();
        bound_dirty_ = false;
    }
    return bound_;
}

void Node::dirty_bound() {
    if (bound_dirty_) return;  // already dirty, and so are the ancestors
    bound_dirty_ = true;
    for (Group* parent : parents_) parent->dirty_bound();
}

Group::~Group() {
    for (const NodePtr& child : children_) std::erase(child->parents_, this);
}

void Group::accept(NodeVisitor& visitor) { visitor.apply(*this); }

void Group::traverse(NodeVisitor& visitor) {
    for (const NodePtr& child : children_) child->accept(visitor);
}

void Group::add(NodePtr child) {
    if (!child) throw std::invalid_argument("Group::add: no node given");
    // A cycle would make traversal endless: the child may not be this group or one of its ancestors.
    std::vector<const Node*> stack{this};
    while (!stack.empty()) {
        const Node* n = stack.back();
        stack.pop_back();
        if (n == child.get())
            throw std::invalid_argument("cannot add '" + child->name() + "' under '" + name() + "': it would contain itself");
        for (const Group* parent : n->parents()) stack.push_back(parent);
    }
    child->parents_.push_back(this);
    children_.push_back(std::move(child));
    dirty_bound();
}

bool Group::remove(const Node* child) {
    auto it = std::find_if(children_.begin(), children_.end(), [&](const NodePtr& c) { return c.get() == child; });
    if (it == children_.end()) return false;
    auto& parents = (*it)->parents_;
    parents.erase(std::find(parents.begin(), parents.end(), this));  // once: a node may be added twice
    children_.erase(it);
    dirty_bound();
    return true;
}

void Group::clear() {
    while (!children_.empty()) remove(children_.back().get());
}

Box Group::compute_bound() const {
    Box box;
    for (const NodePtr& child : children_) box.expand(child->bound());
    return box;
}

void Transform::accept(NodeVisitor& visitor) { visitor.apply(*this); }

void Transform::set_matrix(const glm::dmat4& matrix) {
    matrix_ = matrix;
    dirty_bound();
}

Box Transform::compute_bound() const { return transformed(Group::compute_bound(), matrix_); }

Node* find_node(Node& root, const std::string& name) {
    if (root.name() == name) return &root;
    if (auto* group = dynamic_cast<Group*>(&root))
        for (const NodePtr& child : group->children())
            if (Node* found = find_node(*child, name)) return found;
    return nullptr;
}

NodePtr find_node(const NodePtr& root, const std::string& name) {
    if (root->name() == name) return root;
    if (auto* group = dynamic_cast<Group*>(root.get()))
        for (const NodePtr& child : group->children())
            if (NodePtr found = find_node(child, name)) return found;
    return nullptr;
}

NodePtr find_node(const NodePtr& root, const Node* node) {
    if (root.get() == node) return root;
    if (const auto* group = dynamic_cast<const Group*>(root.get()))
        for (const NodePtr& child : group->children())
            if (NodePtr found = find_node(child, node)) return found;
    return nullptr;
}

bool is_rotation_and_uniform_scale(const glm::dmat4& matrix) {
    const glm::dmat3 linear(matrix);
    const double scale = glm::length(linear[0]);
    if (!(scale > 0) || matrix[0][3] != 0 || matrix[1][3] != 0 || matrix[2][3] != 0 || matrix[3][3] != 1) return false;
    const glm::dmat3 rotation = linear / scale;
    const glm::dmat3 error = glm::transpose(rotation) * rotation - glm::dmat3(1.0);
    for (int column = 0; column < 3; ++column)
        for (int row = 0; row < 3; ++row)
            if (!(std::abs(error[column][row]) <= 1e-9)) return false;
    return glm::determinant(rotation) > 0;
}

}  // namespace strata
