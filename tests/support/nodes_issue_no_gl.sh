#!/usr/bin/env bash
# Nodes draw through engine/render's DrawContext (DrawCall, draw_elements, draw_indirect, ...) and
# engine/gl's wrappers: no OpenGL entry point or constant of their own, so none leaves GL state for the
# next drawable. Lists each offending line and fails when there is one. GLSL's "#extension GL_..."
# lines are shader source, not calls.
set -euo pipefail
root=${1:?usage: nodes_issue_no_gl.sh SOURCE_DIR}
if grep -nE '\bgl[A-Z][A-Za-z0-9]*[[:space:]]*\(|\bGL_[A-Z0-9_]+' "$root"/nodes/*.cpp "$root"/nodes/*.h | grep -v '#extension GL_'; then
    echo "nodes/ calls OpenGL directly (above): submit a DrawCall through the DrawContext instead" >&2
    exit 1
fi
