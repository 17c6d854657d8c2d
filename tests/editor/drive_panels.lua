-- Drives the editor as a person would, through the `editor` object, and checks what it shows.
local function near(a, b, tolerance) return math.abs(a - b) <= (tolerance or 1e-9) end

assert(editor:frame(3), "the window closed by itself")

-- The scene and the panels are on screen: read the window back.
local pixels, width, height = editor:screenshot()
assert(width == 1280 and height == 720, ("window is %dx%d"):format(width, height))
local function pixel(x, y)
    local i = (y * width + x) * 4
    return pixels:byte(i + 1), pixels:byte(i + 2), pixels:byte(i + 3)
end
-- counts pixels in a rectangle passing a test
local function count(x0, y0, x1, y1, test)
    local n = 0
    for y = y0, y1, 2 do for x = x0, x1, 2 do if test(pixel(x, y)) then n = n + 1 end end end
    return n
end
local function bright(r, g, b) return r > 170 and g > 170 and b > 170 end
local function dark(r, g, b) return r < 40 and g < 40 and b < 40 end
-- Panels: the outliner (top left) is a dark window with light text in it.
assert(count(0, 0, 290, 250, dark) > 5000, "no dark panel at the top left")
assert(count(0, 0, 290, 250, bright) > 50, "no text in the outliner")
-- The scene: light-grey models and floor in the middle of the window.
assert(count(400, 150, 880, 500, bright) > 2000, "the scene is not drawn")
-- The console along the bottom.
assert(count(0, 560, 1279, 715, dark) > 20000, "no console")
-- Hidden panels (Tab) leave the scene's background where the outliner was; shown again, it is back.
assert(editor:panels() == true)
assert(editor:panels(false) == false)
pixels = editor:screenshot()
assert(count(0, 0, 290, 250, dark) < 100, "the outliner is drawn while the panels are hidden")
assert(count(400, 150, 880, 500, bright) > 2000, "the scene is not drawn without the panels")
assert(editor:panels(true) == true)
pixels = editor:screenshot()
assert(count(0, 0, 290, 250, dark) > 5000, "the panels did not come back")

-- Outliner and inspector.
assert(editor:select("place2"):name() == "place2")
assert(editor:selected():name() == "place2")
assert(not pcall(editor.select, editor, "nothing"), "selecting a missing name must fail")
local place = editor:selected()
place:set_transform{ translate = { 0, 0.05, 0 } }
assert(editor:frame())
assert(near(place:matrix()[14], 0.05))
local floor = editor:scene():find("floor")
editor:remove(floor)
assert(editor:scene():find("floor") == nil)
local added = editor:add(os.getenv("WORK") .. "/bunny.hlod")
assert(added:name() == "bunny" and editor:selected() == added)
assert(not pcall(editor.add, editor, "missing.hlod"))

-- Bookmarks: the camera goes back to where it was.
local cam = editor:camera()
local home = cam:pose()
editor:bookmark("home")
cam:look_at({ 0.5, 0.5, 0.5 }, { 0, 0.1, 0 })
assert(editor:frame())
assert(editor:go("home"))
assert(not editor:go("nowhere"))
local back = cam:pose()
assert(near(back.position[1], home.position[1]) and near(back.position[3], home.position[3]))
assert(#editor:bookmarks() == 1 and editor:bookmarks()[1] == "home")

-- The path: three keys, a fixed duration on the first segment, scrubbing moves the camera.
assert(editor:add_key() == 1)
assert(editor:duration() == nil)
cam:look_at({ 0.4, 0.3, 0.4 }, { 0, 0.1, 0 })
assert(editor:add_key() == 2)
cam:look_at({ -0.4, 0.3, 0.4 }, { 0, 0.1, 0 })
assert(editor:add_key() == 3)
editor:set_duration(1, 2.0)
local total = editor:duration()
assert(total > 2.0, "duration " .. tostring(total))
editor:scrub(0)
assert(near(cam:pose().position[1], home.position[1], 1e-9))
editor:scrub(2.0)
assert(near(cam:pose().position[1], 0.4, 1e-9) and near(editor:time(), 2.0))
assert(not pcall(editor.scrub, editor, 0 / 0), "a NaN time must be refused")
assert(near(editor:time(), 2.0))
editor:scrub(total)
assert(near(cam:pose().position[1], -0.4, 1e-9))
-- Move key 2 to a new place and check the path goes through it.
cam:look_at({ 0.3, 0.2, 0.5 }, { 0, 0.1, 0 })
editor:move_key(2)
editor:scrub(2.0)
assert(near(cam:pose().position[3], 0.5, 1e-9))
-- Play: the time runs on with the frames.
editor:scrub(0)
editor:play(true)
assert(editor:playing())
assert(editor:frame(3))
assert(editor:time() > 0)
editor:play(false)
-- Save and load the path as JSON.
local file = os.getenv("WORK") .. "/editor_path.json"
editor:save_path(file)
editor:remove_key(3)
assert(editor:keys() == 2)
editor:load_path(file)
assert(editor:keys() == 3)
assert(not pcall(editor.load_path, editor, os.getenv("WORK") .. "/missing.json"))

-- The console runs Lua against the live scene and shows output and errors.
local shown = editor:console("scene:find('place1'):name()")
assert(shown:find('"place1"'), shown)
shown = editor:console("function twice(x)")
assert(editor:console("return 2 * x"))
shown = editor:console("end")
assert(twice(21) == 42, "multi-line function not defined")
shown = editor:console("nosuch.field = 1")
assert(shown:find("attempt to index a nil value"), shown)
-- The editor cannot be replaced from its own console, nor by a scene it cannot open: it stays open.
shown = editor:console("strata.view()")
assert(shown:find("cannot replace the open editor from its own console"), shown)
assert(not pcall(strata.view, strata.plane{ width = 1, depth = 1 }), "a mesh is not a scene to open")
assert(editor:is_open() and editor:frame())
-- Output goes back where it went after a console line run from another one.
shown = editor:console("editor:console('print(1 + 1)'); print('after')")
assert(shown:find("2") and shown:find("after"), shown)

-- Its own cost: the panels are cheap next to the scene.
local stats = editor:stats()
assert(stats.ui_ms > 0 and stats.triangles > 0 and stats.cubes > 0)
editor:screenshot(os.getenv("WORK") .. "/editor.png")
editor:close()
assert(not editor:is_open())
print("editor panels: ok")
