-- strata.video: rendered PNG frames encoded to an MP4 with the asked frame count and rate (checked
-- with ffprobe), and the errors: no frames, ffmpeg missing (by naming a program that does not exist).
local strata = require "strata"
local hlod, out = assert(arg[1]), assert(arg[2])

local scene = strata.scene()
scene:add(strata.load(hlod))
local cam = strata.camera{ width = 96, height = 71 }   -- odd height: the encoder pads it
local c = scene:bounds().center
for i = 0, 11 do
    local a = i / 12 * 2 * math.pi
    cam:look_at({ c[1] + 0.3 * math.sin(a), c[2] + 0.05, c[3] + 0.3 * math.cos(a) }, c)
    strata.render(scene, cam):write(("%s/f%03d.png"):format(out, i))
end
strata.video{ frames = out .. "/f%03d.png", output = out .. "/orbit.mp4", fps = 24, quality = 23 }

local probe = io.popen(("ffprobe -v error -select_streams v:0 -count_frames -show_entries " ..
                        "stream=nb_read_frames,r_frame_rate,codec_name -of default=nw=1 '%s/orbit.mp4'"):format(out))
local info = probe:read("a")
probe:close()
assert(info:find("codec_name=h264"), info)
assert(info:find("r_frame_rate=24/1"), info)
assert(info:find("nb_read_frames=12"), info)

local ok, err = pcall(strata.video, { frames = out .. "/none%03d.png", output = out .. "/x.mp4" })
assert(not ok and err:find("no frame"), err)
assert(io.open(out .. "/x.mp4") == nil)
print("video_api: ok")
