-- strata.video refuses frame patterns other than one %d or %0Nd (and %% for a percent sign) before
-- anything reaches a formatter, and numbers that are no frame numbers or qualities. arg[2] is a
-- folder to write in.
local strata = require "strata"
local t = require "abuse_lib"
local out = assert(arg[2])
local output = out .. "/abuse.mp4"

t.refuses("bad argument #1", strata.video)
t.each_junk_refused("bad argument #1", strata.video, 1, {}, function(v) return type(v) == "table" end)
t.refuses("strata.video needs 'frames'", strata.video, { output = output })
t.refuses("option 'frames' must be a string, got table", strata.video, { frames = {}, output = output })
for _, pattern in ipairs({ "/tmp/%s%s%s%n", "f%d%d.png", "f%x.png", "f%5d.png", "f%010d.png", "f%00d.png", "f.png",
                           "f%", "f%0", "f%%d.png", "%ld", "%-5d", "%.3d", "%*d", "%n", "%1$d" }) do
    t.refuses(("frame pattern '%s/%s'"):format(out, pattern), strata.video, { frames = out .. "/" .. pattern, output = output })
end
-- Accepted patterns look for their first frame (none here).
t.refuses("no frame " .. out .. "/100%_f0007.png", strata.video, { frames = out .. "/100%%_f%04d.png", output = output, first = 7 })
t.refuses("no frame " .. out .. "/f3.png", strata.video, { frames = out .. "/f%d.png", output = output, first = 3 })
t.refuses("option 'first': number has no integer representation", strata.video, { frames = "f%d.png", output = output, first = 0 / 0 })
t.refuses("option 'first': number has no integer representation", strata.video, { frames = "f%d.png", output = output, first = 0.5 })
t.refuses("option 'first' must be 0 to", strata.video, { frames = "f%d.png", output = output, first = -1 })
t.refuses("option 'first' must be 0 to", strata.video, { frames = "f%d.png", output = output, first = math.maxinteger })
t.refuses("option 'quality' must be 0 to 51, got 52", strata.video, { frames = "f%d.png", output = output, quality = 52 })
t.refuses("option 'quality': number has no integer representation", strata.video, { frames = "f%d.png", output = output, quality = math.huge })
t.refuses("the frame rate must be positive", strata.video, { frames = "f%d.png", output = output, fps = 0 / 0 })
t.refuses("the frame rate must be positive", strata.video, { frames = "f%d.png", output = output, fps = math.huge })
assert(not io.open(output), "a refused video left its file")
print("abuse_video: ok")
