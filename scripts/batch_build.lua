-- Builds every scan in a folder (PLY, OBJ, OFF, STL) into a .hlod model, skipping models newer than
-- their scan.   strata run scripts/batch_build.lua SCANS_DIR [OUT_DIR]
local strata = require "strata"
local scans = assert(arg[1], "usage: strata run scripts/batch_build.lua SCANS_DIR [OUT_DIR]")
local out = arg[2] or scans
strata.mkdir(out)

local built, skipped = 0, 0
for _, scan in ipairs(strata.files(scans, { "ply", "obj", "off", "stl" })) do
    local name = scan:match("([^/]+)%.%w+$")
    local model = ("%s/%s.hlod"):format(out, name)
    local scan_time, model_time = strata.modified(scan), strata.modified(model)
    if model_time and model_time >= scan_time then
        print(("%-24s up to date"):format(name))
        skipped = skipped + 1
    else
        local last = ""
        local stats = strata.build{ input = scan, output = model, on_progress = function(stage)
            if stage ~= last then io.stderr:write(("%-24s %s\n"):format(name, stage)); last = stage end
        end }
        print(("%-24s %d triangles, %d levels, %.1f MB in %.2f s"):format(name, stats.triangles, stats.levels,
                                                                      stats.bytes / 1e6, stats.seconds))
        built = built + 1
    end
end
print(("batch_build: %d built, %d up to date"):format(built, skipped))
