#!/usr/bin/env python3
"""Veach's multiple importance sampling figure, rendered by wavetrace once per --mis mode.

    python3 tools/gallery/veach.py                       # GPU, 320 px wide, 32 spp, reference 1024 spp
    python3 tools/gallery/veach.py --device cpu --width 160 --spp 16 --ref-spp 256
    python3 tools/gallery/veach.py --wavetrace PATH      # use that binary instead of building one

Renders scenes/veach-mis.gltf at --spp with each weighting of --modes (same seed), and once at
--ref-spp with the power heuristic and another seed as the reference; measures each mode's
relative MSE against the reference with `wavetrace compare MODE.exr reference.exr` (mean over
pixels and channels of (A - B)^2 / (B^2 + 0.01)); writes OUT_DIR/veach-mis.png, the renders in a
grid with each one's mode and relative MSE above it, and OUT_DIR/veach-mis.md, the table.
The reference's own noise adds about spp / ref-spp of the variance to every mode's error.

Renders and their EXR files go to --work-dir. Python 3 standard library only: the PNG reader
and writer and the 5x7 bitmap font of the labels are below.
"""

import argparse
import os
import re
import struct
import subprocess
import zlib

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
MODES = ["light-only", "bsdf-only", "average", "maximum", "balance", "power"]

# ---------------------------------------------------------------------------------------------
# PNG (ISO/IEC 15948): 8-bit RGB or RGBA, not interlaced, the five row filters of section 9.

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def paeth(a, b, c):
    """The Paeth predictor of PNG section 9.4."""
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    if pa <= pb and pa <= pc:
        return a
    return b if pb <= pc else c


def read_png(path):
    """Returns (width, height, rows), rows a list of bytearrays of RGB triples."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != PNG_SIGNATURE:
        raise ValueError("%s: not a PNG file" % path)
    pos, header, idat = 8, None, bytearray()
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    if header is None:
        raise ValueError("%s: no IHDR chunk" % path)
    width, height, depth, colour, _, _, interlace = header
    if depth != 8 or colour not in (2, 6) or interlace != 0:
        raise ValueError("%s: only 8-bit RGB/RGBA non-interlaced PNG is supported" % path)
    bpp = 3 if colour == 2 else 4
    raw = zlib.decompress(bytes(idat))
    stride = width * bpp
    rows, previous = [], bytearray(stride)
    for y in range(height):
        start = y * (stride + 1)
        kind, row = raw[start], bytearray(raw[start + 1:start + 1 + stride])
        for i in range(stride):
            a = row[i - bpp] if i >= bpp else 0
            b = previous[i]
            c = previous[i - bpp] if i >= bpp else 0
            if kind == 1:
                row[i] = (row[i] + a) & 255
            elif kind == 2:
                row[i] = (row[i] + b) & 255
            elif kind == 3:
                row[i] = (row[i] + (a + b) // 2) & 255
            elif kind == 4:
                row[i] = (row[i] + paeth(a, b, c)) & 255
            elif kind != 0:
                raise ValueError("%s: unknown row filter %d" % (path, kind))
        previous = row
        rows.append(row if bpp == 3 else bytearray(v for i, v in enumerate(row) if i % 4 != 3))
    return width, height, rows


def write_png(path, width, rows):
    """Writes 8-bit RGB rows (bytearrays of width * 3) with filter 0 and zlib."""
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    raw = b"".join(b"\x00" + bytes(row) for row in rows)
    with open(path, "wb") as f:
        f.write(PNG_SIGNATURE)
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, len(rows), 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        f.write(chunk(b"IEND", b""))


# ---------------------------------------------------------------------------------------------
# A 5x7 bitmap font: capital letter shapes for a-z, digits and a few signs; rows top to bottom.

FONT = {
    "a": ".###.|#...#|#...#|#####|#...#|#...#|#...#", "b": "####.|#...#|#...#|####.|#...#|#...#|####.",
    "c": ".###.|#...#|#....|#....|#....|#...#|.###.", "d": "####.|#...#|#...#|#...#|#...#|#...#|####.",
    "e": "#####|#....|#....|####.|#....|#....|#####", "f": "#####|#....|#....|####.|#....|#....|#....",
    "g": ".###.|#...#|#....|#.###|#...#|#...#|.####", "h": "#...#|#...#|#...#|#####|#...#|#...#|#...#",
    "i": ".###.|..#..|..#..|..#..|..#..|..#..|.###.", "j": "..###|...#.|...#.|...#.|...#.|#..#.|.##..",
    "k": "#...#|#..#.|#.#..|##...|#.#..|#..#.|#...#", "l": "#....|#....|#....|#....|#....|#....|#####",
    "m": "#...#|##.##|#.#.#|#.#.#|#...#|#...#|#...#", "n": "#...#|#...#|##..#|#.#.#|#..##|#...#|#...#",
    "o": ".###.|#...#|#...#|#...#|#...#|#...#|.###.", "p": "####.|#...#|#...#|####.|#....|#....|#....",
    "q": ".###.|#...#|#...#|#...#|#.#.#|#..#.|.##.#", "r": "####.|#...#|#...#|####.|#.#..|#..#.|#...#",
    "s": ".####|#....|#....|.###.|....#|....#|####.", "t": "#####|..#..|..#..|..#..|..#..|..#..|..#..",
    "u": "#...#|#...#|#...#|#...#|#...#|#...#|.###.", "v": "#...#|#...#|#...#|#...#|#...#|.#.#.|..#..",
    "w": "#...#|#...#|#...#|#.#.#|#.#.#|#.#.#|.#.#.", "x": "#...#|#...#|.#.#.|..#..|.#.#.|#...#|#...#",
    "y": "#...#|#...#|.#.#.|..#..|..#..|..#..|..#..", "z": "#####|....#|...#.|..#..|.#...|#....|#####",
    "0": ".###.|#...#|#..##|#.#.#|##..#|#...#|.###.", "1": "..#..|.##..|..#..|..#..|..#..|..#..|.###.",
    "2": ".###.|#...#|....#|...#.|..#..|.#...|#####", "3": "#####|...#.|..#..|...#.|....#|#...#|.###.",
    "4": "...#.|..##.|.#.#.|#..#.|#####|...#.|...#.", "5": "#####|#....|####.|....#|....#|#...#|.###.",
    "6": "..##.|.#...|#....|####.|#...#|#...#|.###.", "7": "#####|....#|...#.|..#..|.#...|.#...|.#...",
    "8": ".###.|#...#|#...#|.###.|#...#|#...#|.###.", "9": ".###.|#...#|#...#|.####|....#|...#.|.##..",
    "-": ".....|.....|.....|#####|.....|.....|.....", ".": ".....|.....|.....|.....|.....|.##..|.##..",
    " ": ".....|.....|.....|.....|.....|.....|.....", "=": ".....|.....|#####|.....|#####|.....|.....",
    "+": ".....|..#..|..#..|#####|..#..|..#..|.....", ":": ".....|.##..|.##..|.....|.##..|.##..|.....",
    "(": "...#.|..#..|.#...|.#...|.#...|..#..|...#.", ")": ".#...|..#..|...#.|...#.|...#.|..#..|.#...",
}
GLYPH_W, GLYPH_H, ADVANCE, LINE = 5, 7, 6, 10


def text_width(text, scale):
    return (len(text) * ADVANCE - 1) * scale


def draw_text(canvas, x0, y0, text, scale, colour):
    """Draws `text` (lower case; unknown characters as blanks) with its top-left corner at x0, y0."""
    for n, ch in enumerate(text.lower()):
        for row, bits in enumerate(FONT.get(ch, FONT[" "]).split("|")):
            for col, bit in enumerate(bits):
                if bit != "#":
                    continue
                for dy in range(scale):
                    line = canvas[y0 + row * scale + dy]
                    for dx in range(scale):
                        x = x0 + (n * ADVANCE + col) * scale + dx
                        if 0 <= x < len(line) // 3:
                            line[3 * x:3 * x + 3] = bytes(colour)


# ---------------------------------------------------------------------------------------------
# Rendering and measuring

def wavetrace_binary(args):
    if args.wavetrace:
        return args.wavetrace
    print("building wavetrace (cargo build --release)", flush=True)
    subprocess.run(["cargo", "build", "--release"], cwd=ROOT, check=True)
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    return os.path.join(target, "release", "wavetrace")


def render(binary, args, mode, spp, seed, out):
    command = [binary, "render", os.path.join(ROOT, "scenes", "veach-mis.gltf"), "--mis", mode,
               "--spp", str(spp), "--seed", str(seed), "--width", str(args.width),
               "--device", args.device, "--exposure", str(args.exposure), "-o", out]
    if args.max_depth is not None:
        command += ["--max-depth", str(args.max_depth)]
    print(" ".join(command), flush=True)
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)


def relative_mse(binary, exr, reference):
    """(relative MSE, MSE) from `wavetrace compare` (exit 0 or 1: agreeing or not; 2: error)."""
    result = subprocess.run([binary, "compare", exr, reference], capture_output=True, text=True)
    if result.returncode not in (0, 1):
        raise RuntimeError("wavetrace compare %s %s failed:\n%s" % (exr, reference, result.stderr))
    match = re.search(r"relative MSE = (\S+) .*; MSE = (\S+)", result.stdout)
    if match is None:
        raise RuntimeError("no relative MSE in the output of wavetrace compare:\n" + result.stdout)
    return float(match.group(1)), float(match.group(2))


def compose(panels, columns, path):
    """Writes the (label lines, png path) panels in a grid, each label above its image."""
    images = [(lines, read_png(png)) for lines, png in panels]
    width, height = images[0][1][0], images[0][1][1]
    scale = 2 if width >= 200 else 1
    label_h = (len(images[0][0]) * LINE + 4) * scale
    gap = 4
    rows_n = (len(images) + columns - 1) // columns
    total_w = columns * width + (columns + 1) * gap
    total_h = rows_n * (label_h + height) + (rows_n + 1) * gap
    canvas = [bytearray(b"\x28" * (3 * total_w)) for _ in range(total_h)]
    for k, (lines, (w, h, pixels)) in enumerate(images):
        if (w, h) != (width, height):
            raise ValueError("the renders differ in size")
        x0 = gap + (k % columns) * (width + gap)
        y0 = gap + (k // columns) * (label_h + height + gap)
        for y in range(label_h):
            canvas[y0 + y][3 * x0:3 * (x0 + width)] = bytes(3 * width)
        for n, line in enumerate(lines):
            x = x0 + max(0, (width - text_width(line, scale)) // 2)
            draw_text(canvas, x, y0 + (2 + n * LINE) * scale, line, scale, (255, 255, 255))
        for y in range(height):
            canvas[y0 + label_h + y][3 * x0:3 * (x0 + width)] = pixels[y]
    write_png(path, total_w, canvas)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--wavetrace", help="the wavetrace binary (default: cargo build --release)")
    parser.add_argument("--device", default="gpu", choices=["gpu", "cpu"])
    parser.add_argument("--width", type=int, default=320, help="image width (height from the camera)")
    parser.add_argument("--spp", type=int, default=32, help="samples per pixel of each mode")
    parser.add_argument("--ref-spp", type=int, default=1024, help="samples per pixel of the reference")
    parser.add_argument("--seed", type=int, default=1, help="seed of the modes; the reference uses seed + 1")
    parser.add_argument("--max-depth", type=int, help="passed to wavetrace (default: its own)")
    parser.add_argument("--exposure", type=float, default=0.0, help="PNG exposure in stops")
    parser.add_argument("--modes", default=",".join(MODES), help="comma-separated --mis modes")
    parser.add_argument("--columns", type=int, default=4, help="panels per row of the grid")
    parser.add_argument("--work-dir", default=os.path.join(ROOT, "target", "gallery", "veach"),
                        help="where the renders go")
    parser.add_argument("--out-dir", default=os.path.join(ROOT, "tools", "gallery"),
                        help="where veach-mis.png and veach-mis.md go")
    args = parser.parse_args()
    modes = [m for m in args.modes.split(",") if m]
    if not modes or args.columns < 1 or min(args.width, args.spp, args.ref_spp) < 1:
        parser.error("need at least one mode, one column, and positive --width, --spp, --ref-spp")

    binary = wavetrace_binary(args)
    os.makedirs(args.work_dir, exist_ok=True)
    os.makedirs(args.out_dir, exist_ok=True)

    def work(name):
        return os.path.join(args.work_dir, name)

    reference_seed = args.seed + 1
    for ext in ("exr", "png"):
        render(binary, args, "power", args.ref_spp, reference_seed, work("reference." + ext))
    results = []
    for mode in modes:
        # The same seed gives the same image, so the PNG is the EXR's mean tonemapped.
        for ext in ("exr", "png"):
            render(binary, args, mode, args.spp, args.seed, work(mode + "." + ext))
        rel, mse = relative_mse(binary, work(mode + ".exr"), work("reference.exr"))
        print("%-10s relative MSE %.4e  MSE %.4e" % (mode, rel, mse), flush=True)
        results.append((mode, rel, mse))

    panels = [([mode, "relmse %.3e" % rel], work(mode + ".png")) for mode, rel, _ in results]
    panels.append((["reference", "%d spp" % args.ref_spp], work("reference.png")))
    png = os.path.join(args.out_dir, "veach-mis.png")
    compose(panels, args.columns, png)
    with open(os.path.join(args.out_dir, "veach-mis.md"), "w", encoding="utf-8", newline="\n") as f:
        f.write("# Veach's MIS scene, one render per weighting\n\n![](veach-mis.png)\n\n")
        f.write("`scenes/veach-mis.gltf`, %d px wide, %d spp per mode (seed %d) on the %s; "
                "reference: power heuristic, %d spp (seed %d). Relative MSE: mean over pixels and "
                "channels of (A − B)² / (B² + 0.01) with B the reference (`wavetrace compare`); "
                "the reference's own noise adds about %.1f %% of each mode's variance.\n\n"
                % (args.width, args.spp, args.seed, args.device.upper(), args.ref_spp, reference_seed,
                   100.0 * args.spp / args.ref_spp))
        f.write("| `--mis` | relative MSE | MSE |\n|---|---|---|\n")
        for mode, rel, mse in results:
            f.write("| %s | %.4e | %.4e |\n" % (mode, rel, mse))
        settings = ["--device", args.device, "--width", args.width, "--spp", args.spp,
                    "--ref-spp", args.ref_spp, "--seed", args.seed, "--exposure", args.exposure,
                    "--modes", ",".join(modes)]
        if args.max_depth is not None:
            settings += ["--max-depth", args.max_depth]
        f.write("\nMade by `python3 tools/gallery/veach.py %s`.\n" % " ".join(map(str, settings)))
    print("wrote", png, "and veach-mis.md")


if __name__ == "__main__":
    main()
