-- Real input through the X server: tests/cli/editor_input.sh clicks, drags, presses keys and types with
-- xdotool while this script runs frames. Each stage writes a marker file that tells the sender to go on,
-- then runs frames until the input has had its effect (or fails at a deadline).
local work = assert(os.getenv("WORK"), "WORK must name the test's scratch directory")
local ed = editor
local scene = ed:scene()
local cam = ed:camera()

-- Once the effect is seen, two more frames settle the UI before the next stage's input: ImGui tests what
-- the pointer is over against the windows of the frame before, so a click sent as soon as Tab has shown
-- the panels again would go through the console, not yet drawn, to the view (and pick nothing there).
-- Each frame drawn is counted in the file "frames", so that the sender paces its input by frames (a press,
-- two frames, a move...) rather than by time, which a busy machine stretches.
local frames = 0
local function frame()
    assert(ed:frame(), "the window closed")
    frames = frames + 1
    local file = assert(io.open(work .. "/frames.tmp", "w"))
    file:write(frames, "\n")
    file:close()
    assert(os.rename(work .. "/frames.tmp", work .. "/frames"))
end

local function stage(name, done)
    io.open(work .. "/" .. name, "w"):close()
    local deadline = os.time() + 60
    while not done() do
        frame()
        assert(os.time() < deadline, "no effect of the input within a minute: " .. name)
    end
    frame()
    frame()
end

local function position() return cam:pose().position end
local function distance(a, b) return math.sqrt((a[1] - b[1]) ^ 2 + (a[2] - b[2]) ^ 2 + (a[3] - b[3]) ^ 2) end

-- The middle model alone, in the middle of the window.
scene:find("place1"):visible(false)
scene:find("place3"):visible(false)
cam:look_at({ 0, 0.2, 2.5 }, { 0, 0, 0 })
assert(ed:frame(2))

-- A left click on it selects it (ray against the drawn geometry).
stage("click", function() return ed:selected() and ed:selected():name() == "bunny2" end)

-- A left drag orbits: the eye moves, and the release after a drag picks nothing new.
local before_drag = position()
stage("drag", function() return distance(position(), before_drag) > 1e-3 end)
assert(ed:selected():name() == "bunny2", "the drag changed the selection")
-- It orbits about the point ahead of where the script put the camera, not about an older one.
local from_origin = distance(position(), { 0, 0, 0 })
assert(math.abs(from_origin - distance(before_drag, { 0, 0, 0 })) < 0.25, "the drag moved the eye to " .. from_origin)

-- F switches to fly mode; holding W flies forward, toward the model.
local before_fly = position()
stage("fly", function() return distance(position(), { 0, 0, 0 }) < distance(before_fly, { 0, 0, 0 }) - 1e-3 end)

-- Tab hides the panels, and shows them again.
stage("tab", function() return not ed:panels() end)
stage("tab again", function() return ed:panels() end)

-- A click in the console's input line, then a typed line and Return: it runs against the live scene.
-- The line tries to draw a frame from inside the frame that runs it: refused, the editor lives on.
stage("type", function() return typed == "bunny2" end)
assert(not nested_ok and nested_error:find("cannot run from its console"), tostring(nested_error))

print("editor input: ok")
ed:close()
