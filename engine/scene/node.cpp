#include "engine/scene/node.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unordered_set>

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
    if (bound_dirty_) refresh_bounds();
    return bound_;
}

void Node::refresh_bounds() const {
    // Each node is finished once its dirty children are: then compute_bound only reads cached bounds.
    std::vector<std::pair<const Node*, bool>> stack{{this, false}};  // node, children pushed
    while (!stack.empty()) {
        auto& [node, children_pushed] = stack.back();
        if (!node->bound_dirty_) {  // a node shared by two parents: done on the first visit
            stack.pop_back();
        } else if (children_pushed) {
            node->bound_ = node->compute_bound();
            node->bound_dirty_ = false;
            stack.pop_back();
        } else {
            children_pushed = true;
            if (const auto* group = dynamic_cast<const Group*>(node))
                for (const NodePtr& child : group->children())
                    if (child->bound_dirty_) stack.emplace_back(child.get(), false);
        }
    }
}

void Node::dirty_bound() {
    // A dirty node's ancestors are dirty already: the walk up stops there.
    std::vector<Node*> stack{this};
    while (!stack.empty()) {
        Node* node = stack.back();
        stack.pop_back();
        if (node->bound_dirty_) continue;
        node->bound_dirty_ = true;
        stack.insert(stack.end(), node->parents_.begin(), node->parents_.end());
    }
}

Group::~Group() {
    // Children this group alone keeps die here, and theirs with them: gathered on a list rather than
    // destroyed from each other's destructors, which for a deep chain would overflow the stack.
    std::vector<NodePtr> doomed = std::move(children_);
    for (const NodePtr& child : doomed) std::erase(child->parents_, this);
    while (!doomed.empty()) {
        NodePtr node = std::move(doomed.back());
        doomed.pop_back();
        auto* group = node.use_count() == 1 ? dynamic_cast<Group*>(node.get()) : nullptr;
        if (!group) continue;
        for (NodePtr& child : group->children_) {
            std::erase(child->parents_, group);
            doomed.push_back(std::move(child));
        }
        group->children_.clear();
    }  // each `node` goes with no children left to destroy recursively
}

void Group::accept(NodeVisitor& visitor) { visitor.apply(*this); }

void Group::traverse(NodeVisitor& visitor) {
    for (auto child = children_.rbegin(); child != children_.rend(); ++child) visitor.queue(**child);
}

bool Group::would_contain_itself(const Node& child) const {
    if (&child == this) return true;
    const auto* group = dynamic_cast<const Group*>(&child);
    if (!group || group->children_.empty()) return false;  // nothing below it can be this group
    // Either walk answers: this group below the child, or the child among this group's ancestors.
    // They go a step each in turn, so the cost is that of the smaller (a deep chain built from the
    // leaf up has a large subtree and no ancestors).
    std::vector<const Node*> below{&child}, above{this};
    std::unordered_set<const Node*> seen_below, seen_above;  // shared nodes are walked once
    while (!below.empty() && !above.empty()) {
        const Node* down = below.back();
        below.pop_back();
        if (down == this) return true;
        if (seen_below.insert(down).second)
            if (const auto* g = dynamic_cast<const Group*>(down))
                for (const NodePtr& c : g->children_) below.push_back(c.get());
        const Node* up = above.back();
        above.pop_back();
        if (up == &child) return true;
        if (seen_above.insert(up).second) above.insert(above.end(), up->parents_.begin(), up->parents_.end());
    }
    return false;
}

void Group::add(NodePtr child) {
    if (!child) throw std::invalid_argument("Group::add: no node given");
    // A cycle would make traversal endless.
    if (would_contain_itself(*child))
        throw std::invalid_argument("cannot add '" + child->name() + "' under '" + name() + "': it would contain itself");
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

namespace {

// The first node at or below `root`, depth first, for which `match` holds; nullptr if none.
template <class Match>
NodePtr find_shared(const NodePtr& root, Match match) {
    std::vector<const NodePtr*> stack{&root};
    while (!stack.empty()) {
        const NodePtr& node = *stack.back();
        stack.pop_back();
        if (match(*node)) return node;
        if (const auto* group = dynamic_cast<const Group*>(node.get()))
            for (auto child = group->children().rbegin(); child != group->children().rend(); ++child) stack.push_back(&*child);
    }
    return nullptr;
}

}  // namespace

Node* find_node(Node& root, const std::string& name) {
    std::vector<Node*> stack{&root};
    while (!stack.empty()) {
        Node* node = stack.back();
        stack.pop_back();
        if (node->name() == name) return node;
        if (const auto* group = dynamic_cast<const Group*>(node))
            for (auto child = group->children().rbegin(); child != group->children().rend(); ++child) stack.push_back(child->get());
    }
    return nullptr;
}

NodePtr find_node(const NodePtr& root, const std::string& name) {
    return find_shared(root, [&](const Node& node) { return node.name() == name; });
}

NodePtr find_node(const NodePtr& root, const Node* node) {
    return find_shared(root, [&](const Node& candidate) { return &candidate == node; });
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
