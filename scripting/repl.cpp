#include "scripting/repl.h"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include <lua.hpp>
// libedit's readline emulation (after <cstdio>, which it needs).
#include <editline/readline.h>

#include "scripting/interpreter.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

lua_State* completion_state = nullptr;
std::vector<std::string> completions;

// Names that complete `text`: the keys of the table it names up to its last dot or colon
// (strata.lo → strata.load; node:ad → node:add), else globals and Lua's keywords.
void collect_completions(lua_State* L, const std::string& text) {
    completions.clear();
    const size_t split = text.find_last_of(".:");
    const std::string head = split == std::string::npos ? "" : text.substr(0, split + 1);
    const std::string tail = split == std::string::npos ? text : text.substr(split + 1);
    auto offer = [&](const std::string& name) {
        if (name.compare(0, tail.size(), tail) == 0) completions.push_back(head + name);
    };
    const int top = lua_gettop(L);
    if (head.empty()) {
        for (const char* keyword : {"and", "break", "do", "else", "elseif", "end", "false", "for", "function", "if",
                                    "in", "local", "nil", "not", "or", "repeat", "return", "then", "true", "until", "while"})
            offer(keyword);
        lua_pushglobaltable(L);
    } else {
        // Evaluate the head (without its separator) as a path of names from the globals. Raw lookups:
        // completing runs no __index of the user's (which might fail, or do anything).
        lua_pushglobaltable(L);
        size_t start = 0;
        const std::string path = head.substr(0, head.size() - 1);
        while (start <= path.size() && lua_istable(L, -1)) {
            const size_t end = path.find_first_of(".:", start);
            const std::string name = path.substr(start, end - start);
            lua_pushlstring(L, name.data(), name.size());
            lua_rawget(L, -2);
            lua_remove(L, -2);
            if (end == std::string::npos) break;
            start = end + 1;
        }
        // A userdata (a node, a camera): complete its methods, and those its methods table inherits
        // (a transform's from groups', a group's from every node's).
        if (lua_isuserdata(L, -1) && luaL_getmetafield(L, -1, "__index") != LUA_TNIL) lua_remove(L, -2);
    }
    for (int chain = 0; chain < 8 && lua_istable(L, -1); ++chain) {
        lua_pushnil(L);
        while (lua_next(L, -2)) {
            lua_pop(L, 1);
            if (lua_type(L, -1) == LUA_TSTRING) offer(lua_tostring(L, -1));
        }
        if (head.empty() || !lua_getmetatable(L, -1)) break;
        lua_pushliteral(L, "__index");
        lua_rawget(L, -2);
        lua_remove(L, -2);
        lua_remove(L, -2);
    }
    lua_settop(L, top);
    std::sort(completions.begin(), completions.end());
    completions.erase(std::unique(completions.begin(), completions.end()), completions.end());
}

// Node names for a string being typed after find( — scene:find("bu → "bunny": the names below every
// node held in a global variable.
void collect_node_names(lua_State* L, const std::string& text) {
    completions.clear();
    std::vector<const Node*> stack;
    lua_pushglobaltable(L);
    lua_pushnil(L);
    while (lua_next(L, -2)) {
        if (const NodePtr node = test_node(L, -1)) stack.push_back(node.get());  // the global keeps it
        lua_pop(L, 1);
    }
    lua_pop(L, 1);
    std::vector<const Node*> seen;
    while (!stack.empty()) {
        const Node* node = stack.back();
        stack.pop_back();
        if (std::find(seen.begin(), seen.end(), node) != seen.end()) continue;
        seen.push_back(node);
        if (node->name().compare(0, text.size(), text) == 0) completions.push_back(node->name());
        if (const auto* group = dynamic_cast<const Group*>(node))
            for (const NodePtr& child : group->children()) stack.push_back(child.get());
    }
    std::sort(completions.begin(), completions.end());
    completions.erase(std::unique(completions.begin(), completions.end()), completions.end());
}

// True when the word at `start` is the inside of a string that is find's argument: find("… or find('….
bool in_find_argument(int start) {
    const std::string before(rl_line_buffer, size_t(start));
    for (const char* opening : {"find(\"", "find('"}) {
        const size_t length = std::strlen(opening);
        if (before.size() >= length && before.compare(before.size() - length, length, opening) == 0) return true;
    }
    return false;
}

char* next_completion(const char*, int state) {
    static size_t index;
    if (state == 0) index = 0;
    return index < completions.size() ? strdup(completions[index++].c_str()) : nullptr;
}

char** complete(const char* text, int start, int) {
    // Called from libedit (C): nothing may be thrown through it. A failure offers no completions.
    try {
        if (in_find_argument(start)) collect_node_names(completion_state, text);
        else collect_completions(completion_state, text);
    } catch (...) {
        completions.clear();
    }
    rl_completion_append_character = '\0';
    return rl_completion_matches(text, next_completion);
}

Interpreter* active_interpreter = nullptr;
bool input_ended = false;

// libedit's callback for a finished line (nullptr at Ctrl-D on an empty line).
void on_terminal_line(char* text) {
    if (!text) {
        active_interpreter->finish();
        input_ended = true;
        return;
    }
    if (active_interpreter->feed(text) && !active_interpreter->last_chunk().empty())
        add_history(active_interpreter->last_chunk().c_str());
    std::free(text);
    rl_callback_handler_install(active_interpreter->prompt(), on_terminal_line);
}

// Keys are read one at a time as they come (libedit's callback interface), so windows opened from
// the REPL keep drawing between keystrokes (about 60 times a second) and type-ahead is never dropped.
void run_terminal(Runtime& runtime, Interpreter& interpreter, const ReplOptions& options) {
    completion_state = runtime.state();
    rl_attempted_completion_function = complete;
    rl_basic_word_break_characters = " \t\n\"\\'`@$><=;|&{(,+-*/%^#~[]";
    using_history();
    if (!options.history.empty()) read_history(options.history.c_str());
    std::printf("strata shell: Lua 5.4 with the strata module. Tab completes, Ctrl-D leaves.\n");
    active_interpreter = &interpreter;
    input_ended = false;
    rl_callback_handler_install(interpreter.prompt(), on_terminal_line);
    while (!input_ended) {
        pollfd input{STDIN_FILENO, POLLIN, 0};
        const int ready = poll(&input, 1, runtime.has_live_windows() ? 15 : -1);
        if (ready < 0 && errno != EINTR) break;
        if (ready > 0 && (input.revents & (POLLIN | POLLHUP))) rl_callback_read_char();
        runtime.pump_live_windows();
    }
    rl_callback_handler_remove();
    active_interpreter = nullptr;
    std::printf("\n");
    if (!options.history.empty()) write_history(options.history.c_str());
}

}  // namespace

int run_repl(Runtime& runtime, const ReplOptions& options) {
    Interpreter interpreter(runtime);
    if (isatty(STDIN_FILENO)) {
        run_terminal(runtime, interpreter, options);
    } else {
        std::string text;
        while (std::getline(std::cin, text)) {
            interpreter.feed(text);
            runtime.pump_live_windows();
        }
        interpreter.finish();
    }
    // Windows opened from the REPL stay until they are closed.
    while (runtime.has_live_windows()) runtime.pump_live_windows();
    return 0;
}

}  // namespace strata
