-- Cameras and rendering from Lua: poses, look-at, framing, a rendered frame's pixels and statistics,
-- PNG and EXR output. arg[1] is a .hlod, arg[2] a folder to write in.
local strata = require "strata"
local hlod_path, out = assert(arg[1]), assert(arg[2])

local scene = strata.scene()
local model = strata.load(hlod_path)
scene:add(model)

local cam = strata.camera{ width = 200, height = 150, fov = 45 }
local b = scene:bounds()
cam:look_at({ b.center[1], b.center[2], b.center[3] + 1 }, b.center)
local f = cam:forward()
assert(math.abs(f[3] + 1) < 1e-9, "look_at points down -z")
cam:frame(scene)
local pose = cam:pose()
assert(#pose.orientation == 4 and pose.fov == 45)

-- The pose round-trips, and a target sets the orientation.
local other = strata.camera{ width = 200, height = 150 }
other:set_pose(pose)
local p2 = other:pose()
for i = 1, 3 do assert(math.abs(p2.position[i] - pose.position[i]) < 1e-12) end
other:set_pose{ position = { 0, 0, 5 }, target = { 0, 0, 0 } }
assert(math.abs(other:forward()[3] + 1) < 1e-9)

local frame = strata.render(scene, cam, { channels = "RGBA,Z,id", background = { 0, 0, 0, 0 } })
local w, h = frame:size()
assert(w == 200 and h == 150)
-- The middle of the frame is the model: opaque, drawn (its depth is checked against a pick in
-- pick_api.lua), with the model's id; a corner is empty.
-- Opaque: llvmpipe's 4-sample resolve leaves some covered pixels' alpha one half-float step below 1.
local r, g, bl, a, depth, id = frame:pixel(100, 75)
assert(a >= 1 - 2 ^ -11 and depth < math.huge and id > 0, ("centre: a=%g depth=%g id=%d"):format(a, depth, id))
local _, _, _, a0, depth0, id0 = frame:pixel(0, 0)
assert(a0 == 0 and depth0 == math.huge and id0 == 0, "corner should be background")
local stats = frame:stats()
assert(stats.triangles > 0 and stats.cubes > 0 and stats.draw_calls >= 1 and stats.cull_ms >= 0)

-- Depth is the eye-space distance along the view axis (not along each pixel's ray), whatever the depth
-- buffer's convention: a plane through the origin tilted 45° about x, seen from 3 units in front, has at
-- each pixel the depth its ray meets it at, in perspective and in orthographic projection.
local tilted = strata.scene()
tilted:add(strata.plane{ center = { 0, 0, 0 }, up = { 0, 1, 1 }, width = 40, depth = 40 })
local function check_depths(camera, expected, what)
    local f = strata.render(tilted, camera, { samples = 1, channels = "RGBA,Z" })
    local fw, fh = f:size()
    for _, y in ipairs{ 0, fh // 4, fh // 2, fh - 1 } do
        for _, x in ipairs{ 0, fw // 3, fw - 1 } do
            -- The pixel centre's normalized device y (up); the plane's depth does not vary along x.
            local ny = 1 - (y + 0.5) / fh * 2
            local _, _, _, alpha, z = f:pixel(x, y)
            local want = expected(ny)
            -- alpha > 0.99: covered (the plane's interpolated alpha can come out a hair under 1)
            assert(alpha > 0.99 and math.abs(z - want) <= 2e-5 * want,
                ("%s depth at %d,%d: %.7g, the plane is at %.7g (alpha %g)"):format(what, x, y, z, want, alpha))
        end
    end
end
local tan_y = math.tan(math.rad(45 / 2))
local persp = strata.camera{ width = 200, height = 150, fov = 45 }
persp:look_at({ 0, 0, 3 }, { 0, 0, 0 })
-- The ray (tan_x·nx, tan_y·ny, −1)·t from (0, 0, 3) meets y + z = 0 at t = 3/(1 − tan_y·ny): its depth.
check_depths(persp, function(ny) return 3 / (1 - tan_y * ny) end, "perspective")
local ortho = strata.camera{ width = 200, height = 150, orthographic = true, ortho_height = 4 }
ortho:look_at({ 0, 0, 3 }, { 0, 0, 0 })
-- The ray from (x, 2·ny, 3) along −z meets y + z = 0 at z = −2·ny.
check_depths(ortho, function(ny) return 3 + 2 * ny end, "orthographic")

-- A finer pixel error draws more triangles.
model:set_lod{ pixel_error = 8 }
local coarse = strata.render(scene, cam):stats().triangles
model:set_lod{ pixel_error = 0.25 }
local fine = strata.render(scene, cam):stats().triangles
assert(fine > coarse, ("fine %d, coarse %d"):format(fine, coarse))

frame:write(out .. "/frame.png")
frame:write(out .. "/frame.exr", { channels = { "RGBA", "Z" }, compression = "piz" })
assert(io.open(out .. "/frame.png", "rb") and io.open(out .. "/frame.exr", "rb"))
-- Written in the background: there after flush; a failure surfaces at flush.
frame:write(out .. "/async.exr", { channels = "RGBA,Z", async = true })
frame:write(out .. "/missing-dir/async.png", { async = true })
local flushed, flush_err = pcall(strata.flush)
assert(not flushed and flush_err:find("missing%-dir"), flush_err)
assert(io.open(out .. "/async.exr", "rb"), "the async frame was not written")
local ok, err = pcall(frame.write, frame, out .. "/frame.jpg")
assert(not ok and err:find("%.png or %.exr"), err)
ok, err = pcall(frame.write, frame, out .. "/x.exr", { channels = "RGBA,N" })
assert(not ok and err:find("N"), err)
print("render_api: ok")
