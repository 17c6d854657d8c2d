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

#include "scripting/wrap_scene.h"

namespace strata {

namespace {

// Readable printing of results: tables (sorted keys, nested, depth-limited), strings quoted.
const char* const kPrinter = R"(
local function show(value, indent, seen)
    if type(value) == "string" then return string.format("%q", value) end
    if type(value) ~= "table" then return tostring(value) end
    if seen[value] then return "{...}" end
    if indent > 3 then return "{…}" end
    seen[value] = true
    local keys = {}
    for k in pairs(value) do keys[#keys + 1] = k end
    table.sort(keys, function(a, b)
        if type(a) == type(b) and (type(a) == "number" or type(a) == "string") then return a < b end
        return type(a) < type(b)
    end)
    local parts, pad = {}, string.rep("  ", indent + 1)
    for i, k in ipairs(keys) do
        local key = (type(k) == "number" and k == i) and "" or
                    (type(k) == "string" and k:match("^[%a_][%w_]*$") and k .. " = " or "[" .. show(k, indent + 1, seen) .. "] = ")
        parts[#parts + 1] = pad .. key .. show(value[k], indent + 1, seen)
    end
    seen[value] = nil
    if #parts == 0 then return "{}" end
    local flat = "{ " .. table.concat(parts, ", "):gsub("\n%s*", " "):gsub("^%s+", ""):gsub(",%s+", ", ") .. " }"
    if #flat <= 72 and not flat:find("\n") then return flat end
    return "{\n" .. table.concat(parts, ",\n") .. "\n" .. string.rep("  ", indent) .. "}"
end
return function(...)
    local out = {}
    for i = 1, select("#", ...) do out[i] = show(select(i, ...), 0, {}) end
    if #out > 0 then print(table.concat(out, "\t")) end
end
)";

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
        // Evaluate the head (without its separator) as a path of names from the globals.
        lua_pushglobaltable(L);
        size_t start = 0;
        const std::string path = head.substr(0, head.size() - 1);
        while (start <= path.size() && lua_istable(L, -1)) {
            const size_t end = path.find_first_of(".:", start);
            lua_getfield(L, -1, path.substr(start, end - start).c_str());
            lua_remove(L, -2);
            if (end == std::string::npos) break;
            start = end + 1;
        }
        // A userdata (a node, a camera): complete its methods.
        if (lua_isuserdata(L, -1) && luaL_getmetafield(L, -1, "__index") != LUA_TNIL) lua_remove(L, -2);
    }
    if (lua_istable(L, -1)) {
        lua_pushnil(L);
        while (lua_next(L, -2)) {
            lua_pop(L, 1);
            if (lua_type(L, -1) == LUA_TSTRING) offer(lua_tostring(L, -1));
        }
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
        if (luaL_testudata(L, -1, kNodeType)) stack.push_back(static_cast<NodePtr*>(lua_touserdata(L, -1))->get());
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
    if (in_find_argument(start)) collect_node_names(completion_state, text);
    else collect_completions(completion_state, text);
    rl_completion_append_character = '\0';
    return rl_completion_matches(text, next_completion);
}

// Whether `source` compiles, as Lua's own REPL decides: as an expression ("return " + source), else as
// statements; when neither compiles and the statements stop short (the error is at <eof>), more lines
// are expected.
enum class Chunk { complete, incomplete, invalid };

bool compiles(lua_State* L, const std::string& source, std::string* error = nullptr) {
    const bool ok = luaL_loadbuffer(L, source.data(), source.size(), "=stdin") == LUA_OK;
    if (!ok && error) *error = lua_tostring(L, -1);
    lua_pop(L, 1);
    return ok;
}

Chunk classify(lua_State* L, const std::string& source) {
    std::string error;
    if (compiles(L, "return " + source) || compiles(L, source, &error)) return Chunk::complete;
    const bool at_end = error.size() >= 5 && error.compare(error.size() - 5, 5, "<eof>") == 0;
    return at_end ? Chunk::incomplete : Chunk::invalid;
}

// Runs `source` as an expression whose values are printed, or else as statements.
void evaluate(Runtime& runtime, int printer, const std::string& source) {
    lua_State* L = runtime.state();
    const std::string expression = "return " + source;
    if (luaL_loadbuffer(L, expression.data(), expression.size(), "=stdin") != LUA_OK) {
        lua_pop(L, 1);
        if (luaL_loadbuffer(L, source.data(), source.size(), "=stdin") != LUA_OK) {
            std::fflush(stdout);
            std::fprintf(stderr, "%s\n", lua_tostring(L, -1));
            lua_pop(L, 1);
            return;
        }
    }
    const int base = lua_gettop(L) - 1;
    if (!runtime.protected_call(0, LUA_MULTRET)) return;
    const int results = lua_gettop(L) - base;
    lua_pushvalue(L, printer);
    lua_insert(L, base + 1);
    runtime.protected_call(results, 0);
    std::fflush(stdout);
}

// The state of one REPL: the lines gathered so far for an unfinished chunk, and the printer.
struct Session {
    Runtime& runtime;
    int printer;
    std::string buffer;
    bool finished = false;

    const char* prompt() const { return buffer.empty() ? "strata> " : "   ...> "; }

    // A line typed (or read); a chunk that is complete (or wrong) runs, an unfinished one waits.
    void line(const std::string& text, bool terminal) {
        buffer += buffer.empty() ? text : "\n" + text;
        if (classify(runtime.state(), buffer) == Chunk::incomplete) return;
        if (terminal && !buffer.empty()) add_history(buffer.c_str());
        evaluate(runtime, printer, buffer);
        buffer.clear();
    }
    // End of input: an unfinished chunk runs, to report its error.
    void end() {
        if (!buffer.empty()) evaluate(runtime, printer, buffer);
        buffer.clear();
        finished = true;
    }
};

Session* active_session = nullptr;

// libedit's callback for a finished line (nullptr at Ctrl-D on an empty line).
void on_terminal_line(char* text) {
    if (!text) {
        active_session->end();
        return;
    }
    active_session->line(text, true);
    std::free(text);
    rl_callback_handler_install(active_session->prompt(), on_terminal_line);
}

// Keys are read one at a time as they come (libedit's callback interface), so windows opened from
// the REPL keep drawing between keystrokes and type-ahead is never dropped.
void run_terminal(Session& session, const ReplOptions& options) {
    completion_state = session.runtime.state();
    rl_attempted_completion_function = complete;
    rl_basic_word_break_characters = " \t\n\"\\'`@$><=;|&{(,+-*/%^#~[]";
    using_history();
    if (!options.history.empty()) read_history(options.history.c_str());
    std::printf("strata shell: Lua 5.4 with the strata module. Tab completes, Ctrl-D leaves.\n");
    active_session = &session;
    rl_callback_handler_install(session.prompt(), on_terminal_line);
    while (!session.finished) {
        pollfd input{STDIN_FILENO, POLLIN, 0};
        if (poll(&input, 1, -1) < 0 && errno != EINTR) break;
        if (input.revents & (POLLIN | POLLHUP)) rl_callback_read_char();
    }
    rl_callback_handler_remove();
    active_session = nullptr;
    std::printf("\n");
    if (!options.history.empty()) write_history(options.history.c_str());
}

}  // namespace

int run_repl(Runtime& runtime, const ReplOptions& options) {
    lua_State* L = runtime.state();
    if (luaL_loadstring(L, kPrinter) != LUA_OK || !runtime.protected_call(0, 1)) return 1;
    Session session{runtime, lua_gettop(L), {}};
    if (isatty(STDIN_FILENO)) {
        run_terminal(session, options);
    } else {
        std::string text;
        while (std::getline(std::cin, text)) session.line(text, false);
        session.end();
    }
    lua_settop(L, session.printer - 1);
    return 0;
}

}  // namespace strata
