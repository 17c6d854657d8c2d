// Lua typed a line at a time, as a person does at a prompt (the REPL and the editor's console): lines
// gather until they make a whole chunk; an expression prints its values readably (tables laid out,
// nodes by type and name), statements just run; errors are reported through the runtime's output.
#pragma once

#include <string>

#include "scripting/runtime.h"

namespace strata {

class Interpreter {
public:
    explicit Interpreter(Runtime& runtime);
    ~Interpreter();
    Interpreter(const Interpreter&) = delete;
    Interpreter& operator=(const Interpreter&) = delete;

    // Adds a line; runs the chunk when it is complete (or cannot become valid) and returns true, or
    // returns false while it waits for more lines (an open `function`, a string, a table…).
    bool feed(const std::string& line);
    // End of input: an unfinished chunk runs, to report its error.
    void finish();

    bool waiting() const { return !buffer_.empty(); }
    // The prompt for the next line: "strata> ", or "   ...> " inside an unfinished chunk.
    const char* prompt() const { return waiting() ? "   ...> " : "strata> "; }
    // The chunk run by the last feed() that returned true (for history).
    const std::string& last_chunk() const { return last_chunk_; }

private:
    void evaluate(const std::string& source);

    Runtime& runtime_;
    int printer_;  // registry reference to the printing function
    std::string buffer_;
    std::string last_chunk_;
};

}  // namespace strata
