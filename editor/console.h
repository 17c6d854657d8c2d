// The editor's Lua console: lines typed run in the live runtime through the same Interpreter as the
// REPL (multi-line chunks, expressions printed readably); printed output and errors are kept in a
// scrolling log; the up and down arrows walk the history.
#pragma once

#include <string>
#include <vector>

#include "scripting/interpreter.h"

struct ImGuiInputTextCallbackData;

namespace strata {

struct ConsoleLine {
    std::string text;
    bool error = false;
    bool input = false;  // an echo of what was typed
};

class Console {
public:
    explicit Console(Runtime& runtime) : runtime_(runtime), interpreter_(runtime) {}

    // Runs a line as if typed and entered; its output and errors go to the log.
    void enter(const std::string& line);
    const std::vector<ConsoleLine>& log() const { return log_; }
    // The log's text from line `from` on, one entry per line (tests read what a command printed).
    std::string text(size_t from = 0) const;

    void draw_panel();

private:
    void append(std::string_view text, bool error, bool input);
    static int on_input_event(ImGuiInputTextCallbackData* data);

    Runtime& runtime_;
    Interpreter interpreter_;
    std::vector<ConsoleLine> log_;
    std::vector<std::string> history_;
    int history_position_ = -1;  // −1: not walking the history
    std::string input_;
    bool scroll_to_end_ = false;
    bool refocus_ = false;
};

}  // namespace strata
