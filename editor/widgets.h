// Small pieces the editor's panels share.
#pragma once

#include <exception>
#include <string>

namespace strata {

// A text field for a file name (`hint` while empty) filling the row but for `button` beside it;
// true when the button was pressed.
bool file_field(const char* id, const char* hint, std::string& file, const char* button);

// Runs `action` and returns `done`, or the error's message when it throws: the line a panel shows
// under the button that started it.
template <typename Action>
std::string outcome(Action&& action, std::string done) {
    try {
        action();
        return done;
    } catch (const std::exception& e) {
        return e.what();
    }
}

}  // namespace strata
