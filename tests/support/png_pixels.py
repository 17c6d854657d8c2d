#!/usr/bin/env python3
"""Pixels of the PNGs strata writes, for the CLI tests (plain Python: zlib, no imaging modules).

    png_pixels.py size IMAGE                     -> W H
    png_pixels.py pixel IMAGE X Y                -> R G B A (bytes; X, Y from the top left)
    png_pixels.py box IMAGE R,G,B,A [X0 Y0 X1 Y1] -> x0 y0 x1 y1 count of the pixels unlike the colour
                                                    (within X0 <= x < X1, Y0 <= y < Y1), or "none"
    png_pixels.py runs IMAGE R,G,B,A             -> the widths of the runs of columns that hold a pixel
                                                    unlike the colour, left to right (objects side by side)
    png_pixels.py changed A B [MIN_STEP]         -> changed off_edge: pixels that differ by more than
                                                    MIN_STEP (default 8) in a channel, and how many of them
                                                    are not beside an edge of A (a neighbour unlike the pixel)
    png_pixels.py palette IMAGE R,G,B,A PALETTE_SOURCE
                                                 -> matching shaded exact: of the pixels unlike the colour,
                                                    how many are a level-palette colour times a grey shade,
                                                    and how many are exactly one (unshaded lines)
Colours given as R,G,B,A are linear floats (as --background takes them), compared after 8-bit sRGB
encoding; a colour given as at:X,Y is that pixel's. PALETTE_SOURCE is the source file that declares `level_palette` (read, so it cannot drift).
"""
import re
import struct
import sys
import zlib


def read_png(path):
    """(width, height, rows) with rows[y][x] an (r, g, b, a) tuple: 8-bit RGB or RGBA, not interlaced."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit(f"{path}: not a PNG")
    pos, idat, header = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    width, height, depth, colour, _, _, interlace = header
    if depth != 8 or colour not in (2, 6) or interlace:
        raise SystemExit(f"{path}: depth {depth}, colour type {colour}, interlace {interlace}: not read here")
    channels = 4 if colour == 6 else 3
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, previous = [], bytearray(stride)
    for y in range(height):
        kind = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            left = line[i - channels] if i >= channels else 0
            up = previous[i]
            up_left = previous[i - channels] if i >= channels else 0
            if kind == 1:
                line[i] = (line[i] + left) & 255
            elif kind == 2:
                line[i] = (line[i] + up) & 255
            elif kind == 3:
                line[i] = (line[i] + (left + up) // 2) & 255
            elif kind == 4:
                p = left + up - up_left
                pa, pb, pc = abs(p - left), abs(p - up), abs(p - up_left)
                predictor = left if pa <= pb and pa <= pc else up if pb <= pc else up_left
                line[i] = (line[i] + predictor) & 255
        previous = line
        pixels = [tuple(line[x * channels:(x + 1) * channels]) for x in range(width)]
        rows.append([p if channels == 4 else p + (255,) for p in pixels])
    return width, height, rows


def srgb_byte(linear):
    c = min(max(linear, 0.0), 1.0)
    c = c * 12.92 if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055
    return int(round(c * 255))


def linear(byte):
    c = byte / 255
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def colour_bytes(text, path=None):
    if text.startswith("at:"):
        x, y = (int(v) for v in text[3:].split(","))
        return read_png(path)[2][y][x]
    r, g, b, a = (float(v) for v in text.split(","))
    return (srgb_byte(r), srgb_byte(g), srgb_byte(b), int(round(min(max(a, 0.0), 1.0) * 255)))


def box(path, colour, x0=0, y0=0, x1=None, y1=None):
    width, height, rows = read_png(path)
    x1, y1 = width if x1 is None else x1, height if y1 is None else y1
    found = [(x, y) for y in range(y0, y1) for x in range(x0, x1) if rows[y][x] != colour]
    if not found:
        return "none"
    xs, ys = [p[0] for p in found], [p[1] for p in found]
    return f"{min(xs)} {min(ys)} {max(xs)} {max(ys)} {len(found)}"


def runs(path, colour):
    width, height, rows = read_png(path)
    filled = [any(rows[y][x] != colour for y in range(height)) for x in range(width)] + [False]
    widths, start = [], None
    for x, f in enumerate(filled):
        if f and start is None:
            start = x
        elif not f and start is not None:
            widths.append(x - start)
            start = None
    return " ".join(str(w) for w in widths) or "none"


def changed(path_a, path_b, min_step):
    width, height, a = read_png(path_a)
    width_b, height_b, b = read_png(path_b)
    if (width, height) != (width_b, height_b):
        raise SystemExit(f"{path_a} is {width}x{height}, {path_b} {width_b}x{height_b}")

    def unlike(p, q):
        return max(abs(u - v) for u, v in zip(p, q)) > min_step

    def beside_edge(x, y):
        # An edge of A within one pixel: two neighbouring pixels of A's 3x3 block around (x, y) unlike.
        block = [(i, j) for j in range(max(y - 1, 0), min(y + 2, height)) for i in range(max(x - 1, 0), min(x + 2, width))]
        return any(unlike(a[j][i], a[y][x]) for i, j in block)

    differing = [(x, y) for y in range(height) for x in range(width) if unlike(a[y][x], b[y][x])]
    off_edge = sum(1 for x, y in differing if not beside_edge(x, y))
    return f"{len(differing)} {off_edge}"


def read_palette(source):
    with open(source) as f:
        text = f.read()
    block = re.search(r"level_palette\[\d+\]\s*=\s*vec3\[\d+\]\((.*?)\);", text, re.S)
    if not block:
        raise SystemExit(f"{source}: no level_palette")
    return [tuple(float(v) for v in m) for m in re.findall(r"vec3\(([\d.]+),\s*([\d.]+),\s*([\d.]+)\)", block.group(1))]


def palette(path, background, source):
    """Pixels that are a palette colour under grey light (linear channels in the palette's proportions)."""
    entries = read_palette(source)
    exact_bytes = {tuple(srgb_byte(c) for c in entry) + (255,) for entry in entries}
    width, height, rows = read_png(path)
    total = shaded = exact = 0
    for row in rows:
        for p in row:
            if p == background:
                continue
            total += 1
            exact += p in exact_bytes
            rgb = [linear(c) for c in p[:3]]
            if max(rgb) < 0.05:  # too dark for its proportions to survive 8 bits
                continue
            for entry in entries:
                scale = sum(rgb) / sum(entry)
                if all(abs(c - scale * e) <= 0.02 + 0.04 * c for c, e in zip(rgb, entry)):
                    shaded += 1
                    break
    return f"{total} {shaded} {exact}"


def main(args):
    command = args[0]
    if command == "size":
        width, height, _ = read_png(args[1])
        return f"{width} {height}"
    if command == "pixel":
        _, _, rows = read_png(args[1])
        return " ".join(str(c) for c in rows[int(args[3])][int(args[2])])
    if command == "box":
        limits = [int(v) for v in args[3:7]]
        return box(args[1], colour_bytes(args[2], args[1]), *limits)
    if command == "runs":
        return runs(args[1], colour_bytes(args[2]))
    if command == "changed":
        return changed(args[1], args[2], int(args[3]) if len(args) > 3 else 8)
    if command == "palette":
        return palette(args[1], colour_bytes(args[2]), args[3])
    raise SystemExit(f"unknown command {command}")


if __name__ == "__main__":
    print(main(sys.argv[1:]))
