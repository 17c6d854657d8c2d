-- Embeddings placed, moved and removed in the editor (strata view with this script, WORK holding
-- olinda.hlod and patch.hlod, a site built with its boundary locked): a click on the ground puts the
-- cursor there, and a site embedded from the terrain's panel lands where the read-out says the cursor
-- is; two embeddings of one site get files of their own; a move keeps the embedding selected; what
-- cannot be done is refused with its reason and changes nothing.
local work = assert(os.getenv("WORK"))
local function near(a, b, tolerance) return math.abs(a - b) <= (tolerance or 1e-9) end
local function refused(f, part)
    local ok, err = pcall(f)
    assert(not ok, "accepted")
    assert(tostring(err):find(part, 1, true), err)
end

local t = strata.terrain{ model = work .. "/olinda.hlod", name = "ground" }
editor:scene():add(t)
local ground = t:ground()
local b = ground:bounds()
local h = ground:height_at{ b.center[1], b.center[2] }
editor:camera():look_at({ b.center[1], b.center[2] - 1500, h + 1500 }, { b.center[1], b.center[2], h }, { 0, 0, 1 })
assert(editor:frame(2))
refused(function() editor:embed(work .. "/patch.hlod") end, "select a terrain")

-- The terrain's panel, then a click on its ground (the ground is selected, and the cursor is there).
editor:select(t)
assert(editor:frame(2))
local picked = editor:click(640, 360)
assert(picked == ground, "the click did not land on the ground")
assert(editor:frame(2))
local cursor = assert(editor:geo().cursor, "no cursor read-out")

-- Embedded at the cursor, selected, its panel drawn.
local first = editor:embed(work .. "/patch.hlod")
assert(first:type() == "embedding" and editor:selected() == first, first:type())
local p = t:placement(first)
assert(near(p.at[1], cursor[1]) and near(p.at[2], cursor[2]), ("at %.9f %.9f, the cursor at %.9f %.9f"):format(p.at[1], p.at[2], cursor[1], cursor[2]))
assert(io.open(work .. "/patch_on_olinda.hlod", "rb"), "no embedding file beside the site")
assert(editor:frame(2))

-- A second embedding of the site, elsewhere: a file of its own.
local away = ground:to_geo{ b.center[1] + 1500, b.center[2] + 1000, h }
local second = editor:embed(work .. "/patch.hlod", { at = { away[1], away[2] }, heading = 20 })
assert(#t:embeddings() == 2 and io.open(work .. "/patch_on_olinda_2.hlod", "rb"), "the second embedding shares the first's file")
assert(near(t:placement(first).at[1], cursor[1]), "the first embedding moved")

-- Moved from a node inside it (its site), turned and scaled; the new node selected.
editor:select(second:site())
assert(editor:frame(2))
local moved = editor:move{ heading = 45, scale = 0.5 }
assert(editor:selected() == moved and moved:type() == "embedding" and #t:embeddings() == 2)
p = t:placement(moved)
assert(near(p.heading, 45) and near(p.scale, 0.5) and near(p.at[1], away[1]) and near(p.at[2], away[2]), ("%g %g"):format(p.heading, p.scale))
assert(editor:frame(2))

-- Refused, changing nothing: onto the first embedding, nothing selected to move, a bad option.
refused(function() editor:move{ at = t:placement(first).at } end, "overlaps the zone of")
refused(function() editor:move{ scale = -1 } end, "scale")
assert(editor:selected() == moved and near(t:placement(moved).heading, 45))
editor:select(ground)
refused(function() editor:move{ heading = 1 } end, "select an embedding")

-- From the console (inside a frame, so waited for without frames), a plain mesh embedded straight from
-- its file; then taken out again.
local west = ground:to_geo{ b.center[1] - 1500, b.center[2] - 1000, h }
local shown = editor:console(("editor:embed(%q, { at = { %.9f, %.9f } })"):format(work .. "/patch.off", west[1], west[2]))
assert(#t:embeddings() == 3, "the console's embedding is missing: " .. tostring(shown))
local from_console = editor:selected()
assert(from_console:type() == "embedding" and from_console:info().boundary_vertices > 0, from_console:type())
-- patch.off shares patch.hlod's stem, whose two embeddings hold the first two numbers.
assert(io.open(work .. "/patch_on_olinda_3_site.hlod", "rb"), "no model of the mesh beside its embedding file")
editor:remove(from_console)
assert(editor:frame(2))

-- Removed from the editor.
editor:remove(moved)
assert(#t:embeddings() == 1 and t:embeddings()[1] == first)
assert(editor:frame(2))
editor:close()
print("editor embed: ok")
