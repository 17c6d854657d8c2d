// Shows a frame in a window: the framebuffer's linear colour blitted to the window, encoded to sRGB
// on the way, then the buffers swapped.
#pragma once

#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"

namespace strata {

void present(gl::Framebuffer& frame, gl::Context& window);
// The blit alone, without the swap: a UI is drawn over it before the caller swaps.
void blit_to_window(gl::Framebuffer& frame, gl::Context& window);

}  // namespace strata
