// Lua errors from bindings (scripting/lua_util): a C++ exception escaping a binding becomes a Lua
// error with its message, and error values of any kind read as text, never as a null string.
#include <gtest/gtest.h>

#include <new>
#include <stdexcept>
#include <string>

#include <lua.hpp>

#include "scripting/lua_util.h"

namespace strata {
namespace {

int throws_bad_alloc(lua_State*) { throw std::bad_alloc(); }
int throws_length_error(lua_State*) {
    std::string text;
    text.reserve(text.max_size() + 1);  // std::length_error, as a huge size from a script would give
    return 0;
}

struct LuaState : ::testing::Test {
    void SetUp() override {
        L = luaL_newstate();
        luaL_openlibs(L);
        lua_newtable(L);
        const luaL_Reg functions[] = {{"bad_alloc", throws_bad_alloc}, {"length_error", throws_length_error}, {nullptr, nullptr}};
        lua::set_functions(L, functions);
        lua_setglobal(L, "f");
    }
    void TearDown() override { lua_close(L); }
    // Runs `code` and returns the error, as text.
    std::string error_of(const char* code) {
        EXPECT_NE(luaL_dostring(L, code), LUA_OK) << code;
        std::string text = lua::error_text(L, -1);
        lua_pop(L, 1);
        return text;
    }
    lua_State* L = nullptr;
};

TEST_F(LuaState, ACppExceptionInABindingIsALuaErrorWithItsMessage) {
    EXPECT_EQ(error_of("f.bad_alloc()"), "[string \"f.bad_alloc()\"]:1: std::bad_alloc");  // where it was called
    EXPECT_NE(error_of("f.length_error()").find("basic_string"), std::string::npos);
    // Caught by pcall in the script like any error, with the message as a string.
    ASSERT_EQ(luaL_dostring(L, "local ok, e = pcall(f.bad_alloc) return ok, type(e), e"), LUA_OK);
    EXPECT_FALSE(lua_toboolean(L, -3));
    EXPECT_STREQ(lua_tostring(L, -2), "string");
    EXPECT_NE(std::string(lua_tostring(L, -1)).find("std::bad_alloc"), std::string::npos);
}

TEST_F(LuaState, ErrorValuesOfAnyKindReadAsText) {
    EXPECT_EQ(error_of("error('plain', 0)"), "plain");
    EXPECT_EQ(error_of("error(42)"), "42");
    EXPECT_EQ(error_of("error()"), "(error object is a nil value)");
    EXPECT_EQ(error_of("error({})"), "(error object is a table value)");
    EXPECT_EQ(error_of("error(true)"), "(error object is a boolean value)");
    EXPECT_EQ(error_of("error(setmetatable({}, {__tostring = function() return 'described' end}))"), "described");
    EXPECT_EQ(error_of("error(setmetatable({}, {__tostring = function() return {} end}))"),
              "(error object is a table value whose __tostring failed)");
    EXPECT_EQ(error_of("error(setmetatable({}, {__tostring = function() error('inner') end}))"),
              "(error object is a table value whose __tostring failed)");
    EXPECT_EQ(lua_gettop(L), 0);  // error_text leaves the stack as it found it
}

}  // namespace
}  // namespace strata
