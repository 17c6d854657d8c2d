#include "engine/scene/visitor.h"

#include "engine/scene/camera.h"
#include "engine/scene/drawable.h"
#include "engine/scene/light.h"

namespace strata {

void NodeVisitor::apply(Drawable& drawable) { apply(static_cast<Node&>(drawable)); }
void NodeVisitor::apply(Camera& camera) { apply(static_cast<Node&>(camera)); }
void NodeVisitor::apply(DirectionalLight& light) { apply(static_cast<Node&>(light)); }
void NodeVisitor::apply(AmbientLight& light) { apply(static_cast<Node&>(light)); }

void Drawable::accept(NodeVisitor& visitor) { visitor.apply(*this); }
void DirectionalLight::accept(NodeVisitor& visitor) { visitor.apply(*this); }
void AmbientLight::accept(NodeVisitor& visitor) { visitor.apply(*this); }

}  // namespace strata
