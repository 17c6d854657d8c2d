-- Camera paths from Lua: through every key, constant speed, frames at a rate, poses a camera takes,
-- JSON and OpenSceneGraph .path round trips, and bad keys. arg[2] is a folder to write in.
local strata = require "strata"
local out = assert(arg[2])

local keys = {
    { position = { 0, 1, 5 }, target = { 0, 0.5, 0 }, fov = 50 },
    { position = { 5, 2, 0 }, target = { 0, 0.5, 0 }, fov = 40 },
    { position = { 0, 1.5, -5 }, target = { 0, 0.5, 0 }, fov = 45 },
    { position = { -4, 1, 1 }, target = { 0, 0.5, 0 }, fov = 50 },
}
local path = strata.path{ keys = keys, spline = "catmull-rom", orientation = "look-at", speed = "constant", duration = 12 }
assert(math.abs(path:duration() - 12) < 1e-9 and path:length() > 15)

-- Through every key, at its time.
for k, key in ipairs(keys) do
    local pose = path:sample(path:key_time(k))
    for i = 1, 3 do assert(math.abs(pose.position[i] - key.position[i]) < 1e-6, "key " .. k) end
    assert(math.abs(pose.fov - key.fov) < 1e-9)
end

-- Frames at 30 fps: the count, constant speed within 1 %, unit orientations.
local count, last, speeds = 0, nil, {}
for i, pose in path:frames{ fps = 30 } do
    count = i
    local q = pose.orientation
    assert(math.abs(q[1] ^ 2 + q[2] ^ 2 + q[3] ^ 2 + q[4] ^ 2 - 1) < 1e-9)
    if last then
        local d = 0
        for j = 1, 3 do d = d + (pose.position[j] - last[j]) ^ 2 end
        speeds[#speeds + 1] = math.sqrt(d)
    end
    last = pose.position
end
assert(count == path:frame_count{ fps = 30 } and count == 361, count)
local s = strata.summary(speeds)
assert(s.max / s.min < 1.01, ("speed varies %.4f"):format(s.max / s.min))

-- A camera takes a pose as it is.
local cam = strata.camera()
cam:set_pose(path:sample(3))
assert(math.abs(cam:pose().position[1] - path:sample(3).position[1]) < 1e-12)

-- JSON and .path round trips.
path:save(out .. "/tour.json")
local again = strata.load_path(out .. "/tour.json")
for _, t in ipairs{ 0, 2.5, 7, 12 } do
    local a, b = path:sample(t), again:sample(t)
    for i = 1, 3 do assert(math.abs(a.position[i] - b.position[i]) < 1e-9) end
end
path:export_osg(out .. "/tour.path")
local osg = strata.import_osg_path(out .. "/tour.path", { orientation = "slerp" })
assert(math.abs(osg:duration() - 12) < 1e-9)
local p = osg:sample(osg:key_time(2))
for i = 1, 3 do assert(math.abs(p.position[i] - keys[2].position[i]) < 1e-6) end

-- Bad input: a clear error.
local ok, err = pcall(strata.path, { keys = { { position = { 0, 0, 0 } } } })
assert(not ok, "one key is not a path")
ok, err = pcall(strata.path, { keys = keys, spline = "cubic" })
assert(not ok and err:find("spline"), err)
ok, err = pcall(strata.path, { keys = { { target = { 0, 0, 0 } }, { position = { 1, 0, 0 } } } })
assert(not ok and err:find("position"), err)
ok, err = pcall(strata.load_path, out .. "/missing.json")
assert(not ok and err:find("missing.json"), err)
print("path_api: ok")
