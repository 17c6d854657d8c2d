#include "editor/console.h"

#include <imgui.h>
#include <imgui_stdlib.h>

namespace strata {

void Console::append(std::string_view text, bool error, bool input) {
    // One log entry per line; a trailing newline ends the last line rather than starting an empty one.
    size_t start = 0;
    while (start < text.size()) {
        const size_t end = text.find('\n', start);
        const size_t stop = end == std::string_view::npos ? text.size() : end;
        log_.push_back({std::string(text.substr(start, stop - start)), error, input});
        start = stop + 1;
    }
    scroll_to_end_ = true;
}

void Console::enter(const std::string& line) {
    append(std::string(interpreter_.prompt()) + line, false, true);
    if (!line.empty() && (history_.empty() || history_.back() != line)) history_.push_back(line);
    history_position_ = -1;
    // Output and errors of this line come to the log instead of where they went (the terminal, or
    // another console's line that runs this one), and go back there afterwards, whatever happens.
    struct RestoreSink {
        Runtime& runtime;
        Runtime::OutputSink previous;
        ~RestoreSink() { runtime.set_output_sink(std::move(previous)); }
    } restore{runtime_, runtime_.set_output_sink([this](std::string_view text, bool error) { append(text, error, false); })};
    interpreter_.feed(line);
}

std::string Console::text(size_t from) const {
    std::string all;
    for (size_t i = from; i < log_.size(); ++i) all += log_[i].text + "\n";
    return all;
}

int Console::on_input_event(ImGuiInputTextCallbackData* data) {
    auto& console = *static_cast<Console*>(data->UserData);
    if (data->EventFlag != ImGuiInputTextFlags_CallbackHistory || console.history_.empty()) return 0;
    const int last = int(console.history_.size()) - 1;
    int& position = console.history_position_;
    if (data->EventKey == ImGuiKey_UpArrow) position = position < 0 ? last : std::max(0, position - 1);
    else if (data->EventKey == ImGuiKey_DownArrow && position >= 0) position = position < last ? position + 1 : -1;
    data->DeleteChars(0, data->BufTextLen);
    if (position >= 0) data->InsertChars(0, console.history_[size_t(position)].c_str());
    return 0;
}

void Console::draw_panel() {
    const float input_height = ImGui::GetFrameHeightWithSpacing();
    ImGui::BeginChild("log", ImVec2(0, -input_height), false, ImGuiWindowFlags_HorizontalScrollbar);
    ImGuiListClipper clipper;  // only the visible lines are laid out: a long log costs nothing
    clipper.Begin(int(log_.size()));
    while (clipper.Step()) {
        for (int i = clipper.DisplayStart; i < clipper.DisplayEnd; ++i) {
            const ConsoleLine& line = log_[size_t(i)];
            const ImVec4 colour = line.error ? ImVec4(1.0f, 0.45f, 0.4f, 1.0f)
                                  : line.input ? ImVec4(0.6f, 0.8f, 1.0f, 1.0f)
                                               : ImGui::GetStyleColorVec4(ImGuiCol_Text);
            ImGui::TextColored(colour, "%s", line.text.c_str());
        }
    }
    if (scroll_to_end_) ImGui::SetScrollHereY(1.0f);
    scroll_to_end_ = false;
    ImGui::EndChild();
    ImGui::TextUnformatted(interpreter_.prompt());
    ImGui::SameLine();
    ImGui::SetNextItemWidth(-1);
    if (refocus_) ImGui::SetKeyboardFocusHere();
    refocus_ = false;
    const ImGuiInputTextFlags flags = ImGuiInputTextFlags_EnterReturnsTrue | ImGuiInputTextFlags_CallbackHistory;
    if (ImGui::InputText("##input", &input_, flags, on_input_event, this)) {
        enter(input_);
        input_.clear();
        refocus_ = true;  // keep typing
    }
}

}  // namespace strata
