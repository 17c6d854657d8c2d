#include "editor/widgets.h"

#include <imgui.h>
#include <imgui_stdlib.h>

namespace strata {

bool file_field(const char* id, const char* hint, std::string& file, const char* button) {
    ImGui::PushID(id);
    const ImGuiStyle& style = ImGui::GetStyle();
    ImGui::SetNextItemWidth(-(ImGui::CalcTextSize(button).x + 2 * style.FramePadding.x + style.ItemSpacing.x));
    ImGui::InputTextWithHint("##file", hint, &file);
    ImGui::SameLine();
    const bool pressed = ImGui::Button(button);
    ImGui::PopID();
    return pressed;
}

}  // namespace strata
