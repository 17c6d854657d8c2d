#include "engine/scene/visitor.h"

#include "engine/scene/camera.h"
#include "engine/scene/drawable.h"
#include "engine/scene/light.h"

namespace strata {

void NodeVisitor::traverse(Node& node, std::function<void()> after) {
    if (after) {  // below the children: runs after them
        pending_.push_back(nullptr);
        afters_.push_back(std::move(after));
    }
    node.traverse(*this);
    if (walking_) return;
    // The outermost call: visit until the stack is empty. An exception leaves the visitor reusable.
    struct Reset {
        NodeVisitor& visitor;
        ~Reset() {
            visitor.walking_ = false;
            visitor.pending_.clear();
            visitor.afters_.clear();
        }
    } reset{*this};
    walking_ = true;
    while (!pending_.empty()) {
        Node* next = pending_.back();
        pending_.pop_back();
        if (next) {
            next->accept(*this);
        } else {
            const std::function<void()> after = std::move(afters_.back());
            afters_.pop_back();
            after();
        }
    }
}

void NodeVisitor::apply(Drawable& drawable) { apply(static_cast<Node&>(drawable)); }
void NodeVisitor::apply(Camera& camera) { apply(static_cast<Node&>(camera)); }
void NodeVisitor::apply(DirectionalLight& light) { apply(static_cast<Node&>(light)); }
void NodeVisitor::apply(AmbientLight& light) { apply(static_cast<Node&>(light)); }

void Drawable::accept(NodeVisitor& visitor) { visitor.apply(*this); }
void DirectionalLight::accept(NodeVisitor& visitor) { visitor.apply(*this); }
void AmbientLight::accept(NodeVisitor& visitor) { visitor.apply(*this); }

}  // namespace strata
