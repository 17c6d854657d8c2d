// Node types (scripting/node_types.h): one declaration per type gives the name Lua, tostring and the
// editor use, the methods each type's Lua values have (their own and their base types', nothing of a
// sibling's), and inspector fields that edit the node.
#include <gtest/gtest.h>

#include <map>

#include "engine/scene/light.h"
#include "nodes/geometry.h"
#include "nodes/hlod_model.h"
#include "scripting/node_types.h"
#include "scripting/runtime.h"
#include "scripting/wrap_scene.h"
#include "tests/support/bunny_model.h"

namespace strata {
namespace {

// Every kind of node the engine has, with the type name scripts know it by.
std::vector<std::pair<NodePtr, std::string>> one_of_each() {
    std::vector<std::pair<NodePtr, std::string>> nodes = {
        {std::make_shared<Group>(), "group"},
        {std::make_shared<Transform>(), "transform"},
        {Geometry::plane({0, 0, 0}, {0, 1, 0}, 1, 1), "geometry"},
        {std::make_shared<DirectionalLight>(), "light"},
        {std::make_shared<AmbientLight>(), "ambient"},
        {std::make_shared<Node>(), "node"},
    };
    if (!test::bunny_hlod().empty()) nodes.emplace_back(HlodModel::open(test::bunny_hlod()), "hlod");
    return nodes;
}

TEST(NodeTypes, OneNameForScriptsTostringAndTheEditor) {
    for (const auto& [node, name] : one_of_each()) {
        node->set_name("x");
        EXPECT_EQ(node_type_of(*node).name, name);
        Runtime runtime;
        lua_State* L = runtime.state();
        push_node(L, node);
        lua_setglobal(L, "n");
        const std::string check = "assert(n:type() == '" + name + "', n:type()); assert(tostring(n):find(\"^strata%." + name +
                                  " 'x'\"), tostring(n)); assert(getmetatable(n) == 'strata.Node')";
        EXPECT_EQ(runtime.run_string(check, "check"), 0) << name;
    }
}

TEST(NodeTypes, DerivedTypesComeBeforeTheirBasesInTheList) {
    const std::span<const NodeType* const> types = node_types();
    for (size_t i = 0; i < types.size(); ++i) {
        const std::vector<const NodeType*> chain = type_chain(*types[i]);
        EXPECT_EQ(chain.front(), &kNodeBaseType);
        EXPECT_EQ(chain.back(), types[i]);
        // node_type_of takes the first match: a base listed before its derived type would hide it.
        for (size_t j = 0; j < i; ++j)
            EXPECT_EQ(std::find(chain.begin(), chain.end() - 1, types[j]), chain.end() - 1) << types[j]->name << " before " << types[i]->name;
    }
}

TEST(NodeTypes, EachTypeHasItsOwnAndItsBasesMethodsOnly) {
    if (test::bunny_hlod().empty()) GTEST_SKIP() << "data/bunny.off is missing";
    Runtime runtime;
    lua_State* L = runtime.state();
    push_node(L, HlodModel::open(test::bunny_hlod()));
    lua_setglobal(L, "model");
    const char* check = R"(
        local g, t, light = strata.group(), strata.transform(), strata.light()
        assert(g.add and g.count and g.name and g.find and not g.matrix and not g.set_lod)
        assert(t.add and t.matrix and t.set_transform and t.name and not t.set_lod)
        assert(model.set_lod and model.height_at and model.name and not model.add and not model.matrix)
        assert(light.name and light.bounds and not light.add and not light.set_lod)
        -- A method used on another type's node names what it needs.
        local ok, err = pcall(t.matrix, g)
        assert(not ok and err:find("transform expected, got node"), err)
        ok, err = pcall(model.set_lod, t, {})
        assert(not ok and err:find("HLOD model expected"), err)
        -- The methods tables are protected too.
        ok, err = pcall(setmetatable, debug.getmetatable(t).__index, {})
        assert(not ok and err:find("protected metatable"), err)
    )";
    EXPECT_EQ(runtime.run_string(check, "check"), 0);
}

// An inspector that answers each field from a script of labels → new values, and records the labels.
class ScriptedInspector : public Inspector {
public:
    std::map<std::string, double> numbers;
    std::map<std::string, bool> toggles;
    std::map<std::string, int> choices;
    std::map<std::string, glm::dvec3> vectors;
    std::vector<std::string> shown;

    bool slider(const char* label, double& value, double, double, const char*) override { return answer(numbers, label, value); }
    bool number(const char* label, double& value, const char*) override { return answer(numbers, label, value); }
    bool vector(const char* label, glm::dvec3& value, const char*) override { return answer(vectors, label, value); }
    bool toggle(const char* label, bool& value) override { return answer(toggles, label, value); }
    bool choice(const char* label, int& value, std::span<const char* const>) override { return answer(choices, label, value); }
    void text(const std::string& line) override { shown.push_back(line); }
    void note(const std::string& line) override { shown.push_back(line); }

private:
    template <class Map, class T>
    bool answer(const Map& script, const char* label, T& value) {
        shown.push_back(label);
        const auto it = script.find(label);
        if (it == script.end() || it->second == value) return false;
        value = it->second;
        return true;
    }
};

void inspect(Node& node, Inspector& fields) {
    for (const NodeType* type : type_chain(node_type_of(node)))
        if (type->inspect) type->inspect(node, fields);
}

TEST(NodeTypes, InspectorFieldsEditTheModel) {
    if (test::bunny_hlod().empty()) GTEST_SKIP() << "data/bunny.off is missing";
    const auto model = HlodModel::open(test::bunny_hlod());
    model->set_pixel_error(1.0);  // as strata.load does
    ScriptedInspector fields;
    fields.toggles["morph"] = false;
    fields.toggles["cube boxes"] = true;
    fields.choices["view"] = int(HlodDebugView::wireframe);
    fields.numbers["pixel error"] = 3.5;
    inspect(*model, fields);
    EXPECT_FALSE(model->morph());
    EXPECT_TRUE(model->show_cube_boxes());
    EXPECT_EQ(model->debug_view(), HlodDebugView::wireframe);
    EXPECT_EQ(model->pixel_error(), 3.5);
    // Switching to κ0 keeps the κ0 in use; the next frame shows its slider instead.
    ScriptedInspector by_kappa0;
    by_kappa0.choices["detail by"] = 1;
    inspect(*model, by_kappa0);
    EXPECT_LE(model->pixel_error(), 0);
    ScriptedInspector next;
    next.numbers["kappa0"] = 7;
    inspect(*model, next);
    EXPECT_EQ(model->kappa0(), 7);
    EXPECT_NE(std::find(next.shown.begin(), next.shown.end(), model->path().string()), next.shown.end());
}

TEST(NodeTypes, InspectorFieldsEditTheTransform) {
    Transform transform;
    ScriptedInspector fields;
    fields.vectors["translate"] = {1, 2, 3};
    fields.numbers["scale"] = 2;
    inspect(transform, fields);
    EXPECT_EQ(glm::dvec3(transform.matrix()[3]), glm::dvec3(1, 2, 3));
    EXPECT_DOUBLE_EQ(glm::length(glm::dvec3(transform.matrix()[0])), 2);
    // A sheared matrix offers its translation only, and says so.
    glm::dmat4 shear(1.0);
    shear[1][0] = 0.5;
    transform.set_matrix(shear);
    ScriptedInspector sheared;
    sheared.numbers["scale"] = 3;  // not offered: must change nothing
    inspect(transform, sheared);
    EXPECT_EQ(transform.matrix(), shear);
    EXPECT_EQ(std::count(sheared.shown.begin(), sheared.shown.end(), "scale"), 0);
    EXPECT_NE(std::find(sheared.shown.begin(), sheared.shown.end(), "general matrix: translation only"), sheared.shown.end());
}

}  // namespace
}  // namespace strata
