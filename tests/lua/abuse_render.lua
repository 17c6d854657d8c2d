-- Cameras, render and frames refuse what they cannot use (abuse_lib.lua); frames can be released
-- (frame:release(), `<close>`), and frames dropped without a collection do not pile up: the collector
-- is told what their pixels weigh. arg[1] is a .hlod, arg[2] a folder to write in.
local strata = require "strata"
local t = require "abuse_lib"
local hlod_path, out = assert(arg[1]), assert(arg[2])

-- Cameras.
for _, bad in ipairs({ 0 / 0, math.huge, 1e300, 1.5, -3 }) do
    local expected = (bad ~= bad or bad == 1.5 or math.abs(bad) == math.huge or bad == 1e300) and "no integer representation"
                     or "must be 1 to 16384"
    t.refuses(expected, strata.camera, { width = bad })
    t.refuses(expected, strata.camera, { height = bad })
end
t.refuses("option 'width' must be 1 to 16384, got 0", strata.camera, { width = 0 })
t.refuses("option 'height' must be 1 to 16384, got 16385", strata.camera, { height = 16385 })
t.refuses("option 'width' must be a number, got string", strata.camera, { width = "wide" })
t.refuses("option 'fov' must be between 0 and 180", strata.camera, { fov = 0 / 0 })
local posed = strata.camera()
t.refuses("option 'fov' must be between 0 and 180", posed.set_pose, posed, { fov = math.huge })
t.refuses("option 'ortho_height' must be a positive number", strata.camera, { ortho_height = 0 / 0 })
t.refuses("options 'near' and 'far' must be distances", strata.camera, { near = -1 })
t.refuses("options 'near' and 'far' must be distances", strata.camera, { near = math.huge })
t.refuses("options 'near' and 'far' must be distances", strata.camera, { far = 0 / 0 })
t.refuses("3 finite numbers", strata.camera, { position = { 0 / 0, 0, 0 } })
local cam = strata.camera{ width = 32, height = 24 }
t.methods_refuse_other_selves(cam, "strata.Camera")
t.refuses("3 finite numbers", cam.look_at, cam, { 0, 0, 1 }, { math.huge, 0, 0 })
t.refuses("strata.Node expected", cam.frame, cam, cam)
t.refuses("the node has no bounds", cam.frame, cam, strata.group())
t.refuses("bad argument #2", cam.set_pose, cam, nil)
t.refuses("bad argument #2", cam.set, cam, "fov")
t.protected_and_finalizable(strata.camera(), "strata.Camera")

-- render.
local scene = strata.scene()
scene:add(strata.load(hlod_path))
cam:frame(scene)
t.refuses("strata.Node expected, got no value", strata.render)
t.refuses("strata.Camera expected, got strata.Node", strata.render, scene, scene)
t.refuses("option 'samples' must be 1, 2, 4 or 8", strata.render, scene, cam, { samples = 3 })
t.refuses("option 'samples': number has no integer representation", strata.render, scene, cam, { samples = 0 / 0 })
t.refuses("option 'samples': number has no integer representation", strata.render, scene, cam, { samples = 1e300 })
t.refuses("option 'background' must be a finite number within float range", strata.render, scene, cam, { background = { 1e300 } })
t.refuses("number expected, got table", strata.render, scene, cam, { background = { {} } })
t.refuses("option 'channels'", strata.render, scene, cam, { channels = "RGBA,%s%n" })
t.refuses("option 'channels' must list channel names", strata.render, scene, cam, { channels = { 1 } })

-- Frames.
local frame = strata.render(scene, cam)
t.methods_refuse_other_selves(frame, "strata.Frame")
t.refuses("no integer representation", frame.pixel, frame, 0 / 0, 0)
t.refuses("outside the image", frame.pixel, frame, math.maxinteger, 0)
t.refuses("outside the image", frame.pixel, frame, 0, math.mininteger)
t.refuses("the file name must end in .png or .exr", frame.write, frame, out .. "/%s%n")
t.refuses("option 'threads' must be 1 to 1024", frame.write, frame, out .. "/f.exr", { threads = 0 })
t.refuses("option 'threads': number has no integer representation", frame.write, frame, out .. "/f.exr", { threads = 0 / 0 })
t.refuses("bad argument #2", frame.write, frame, {})
t.protected_and_finalizable(strata.render(scene, cam), "strata.Frame")

-- release and <close>: the pixels go now, and the frame says so afterwards.
local released = strata.render(scene, cam)
released:release()
released:release()  -- again: harmless
t.refuses("strata.Frame has been released", released.size, released)
t.refuses("strata.Frame has been released", released.write, released, out .. "/r.png")
local escaped
do
    local f <close> = strata.render(scene, cam)
    assert(f:size() == 32)
    escaped = f
end
t.refuses("strata.Frame has been released", escaped.pixel, escaped, 0, 0)

-- Frames dropped in a loop, never collected by hand: memory stays bounded. 512 × 512 RGBA + Z is
-- 5 MB of pixels each; the collector saw 16 bytes per frame and let hundreds pile up.
local big = strata.camera{ width = 512, height = 512 }
big:frame(scene)
for _ = 1, 10 do strata.render(scene, big, { channels = "RGBA,Z", samples = 1 }) end
local before = t.rss_mb()
local count = 200
for _ = 1, count do strata.render(scene, big, { channels = "RGBA,Z", samples = 1 }) end
local growth = t.rss_mb() - before
print(("abuse_render: %d dropped 512x512 RGBA,Z frames grew RSS by %.0f MB (%.0f MB of pixels in all)"):format(
    count, growth, count * 512 * 512 * 20 / 2 ^ 20))
-- Unbounded, this is the whole 1000 MB; the allowance covers the sanitizer's quarantine of freed memory.
assert(growth < 400, ("RSS grew by %.0f MB"):format(growth))
print("abuse_render: ok")
