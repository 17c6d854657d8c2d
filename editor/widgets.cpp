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

bool ImGuiInspector::slider(const char* label, double& value, double lo, double hi, const char* format) {
    return ImGui::SliderScalar(label, ImGuiDataType_Double, &value, &lo, &hi, format, ImGuiSliderFlags_Logarithmic);
}

bool ImGuiInspector::number(const char* label, double& value, const char* format) {
    return ImGui::InputScalar(label, ImGuiDataType_Double, &value, nullptr, nullptr, format);
}

bool ImGuiInspector::vector(const char* label, glm::dvec3& value, const char* format) {
    return ImGui::InputScalarN(label, ImGuiDataType_Double, &value.x, 3, nullptr, nullptr, format);
}

bool ImGuiInspector::toggle(const char* label, bool& value) { return ImGui::Checkbox(label, &value); }

// Radio buttons on one line for two or three options, a combo for more.
bool ImGuiInspector::choice(const char* label, int& value, std::span<const char* const> options) {
    const int count = int(options.size());
    if (count > 3)
        return ImGui::Combo(label, &value, [](void* data, int i, const char** text) {
            *text = static_cast<const char* const*>(data)[i];
            return true;
        }, const_cast<const char**>(options.data()), count);
    ImGui::PushID(label);
    const int before = value;
    for (int i = 0; i < count; ++i) {
        if (i) ImGui::SameLine();
        ImGui::RadioButton(options[size_t(i)], &value, i);
    }
    ImGui::PopID();
    return value != before;
}

void ImGuiInspector::text(const std::string& line) { ImGui::TextUnformatted(line.c_str()); }

void ImGuiInspector::note(const std::string& line) { ImGui::TextDisabled("%s", line.c_str()); }

}  // namespace strata
