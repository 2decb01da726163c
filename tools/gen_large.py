#!/usr/bin/env python3
"""Writes the scale scenes: scenes larger than one GPU storage binding holds, written where you
say (they are large and generated, so none is committed).

    python3 tools/gen_large.py terrain OUT.gltf [--triangles 5000000] [--texture 8192]
    python3 tools/gen_large.py helmets OUT.glb --helmet ../shared/gltf-samples/valid/DamagedHelmet.glb [--count 1000]

- terrain: a rolling heightfield of at least --triangles triangles (a square grid of quads,
  two triangles each, 32-bit indices, per-vertex normals and UVs) under a sun
  (KHR_lights_punctual directional), with a --texture² base-colour map (colour bands and a
  grid) and a metallic-roughness map a quarter as wide. At 5 M triangles its triangles
  (240 MB), vertices (160 MB) and BVH nodes (161 MB) and, at 8192², its texels (362 MiB with
  mip levels) each exceed lavapipe's 128 MiB binding, so each of them is split across
  bindings.
- helmets: --count DamagedHelmets (Khronos sample model, CC BY 4.0: see the samples folder's
  README) on a square grid, all placements of the model's one mesh (15 452 triangles; 15.5 M
  as placed) and its 2048² textures, copied from the .glb given (its binary chunk is kept as it
  is), seen low over the front row under a sun. The emissive texture is left out unless
  --keep-emission: wavetrace stores every placement of an emitting mesh in world space (its
  emitter table samples world-space triangles), which would bake 1000 copies of the helmet
  (15.5 M triangles, 13 GB of host memory) instead of instancing one.

Output is deterministic. Python 3 standard library only (struct, zlib).
"""

import argparse
import json
import math
import struct
import sys
import zlib
from array import array

FLOAT, UNSIGNED_INT = 5126, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


def png(width, height, rows):
    """An 8-bit RGB PNG of `height` rows (bytes of 3 * width each) from the iterable `rows`."""
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    z = zlib.compressobj(1)
    parts = []
    for row in rows:
        parts.append(z.compress(b"\x00" + row))
    parts.append(z.flush())
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", b"".join(parts))
            + chunk(b"IEND", b""))


def height(x, z):
    """The terrain's height at (x, z) in [0, 1]^2: a few octaves of sines, about ±0.06."""
    return (0.04 * math.sin(6.1 * x + 1.3) * math.cos(5.3 * z)
            + 0.015 * math.sin(23.0 * x + 17.0 * z)
            + 0.006 * math.cos(71.0 * z - 43.0 * x))


def grad(x, z):
    e = 1e-4
    return ((height(x + e, z) - height(x - e, z)) / (2 * e),
            (height(x, z + e) - height(x, z - e)) / (2 * e))


def terrain(out, triangles, texture):
    n = math.ceil(math.sqrt(triangles / 2))  # quads per side
    verts = n + 1
    print(f"terrain: {n} x {n} quads, {2 * n * n} triangles, {verts * verts} vertices", file=sys.stderr)
    pos, nor, uv = array("f"), array("f"), array("f")
    for j in range(verts):
        z = j / n
        for i in range(verts):
            x = i / n
            y = height(x, z)
            gx, gz = grad(x, z)
            inv = 1.0 / math.sqrt(gx * gx + 1.0 + gz * gz)
            pos.extend((x - 0.5, y, z - 0.5))
            nor.extend((-gx * inv, inv, -gz * inv))
            uv.extend((x, z))
    idx = array("I")
    for j in range(n):
        row = j * verts
        for i in range(n):
            a = row + i
            b, c, d = a + 1, a + verts, a + verts + 1
            # Counter-clockwise seen from +Y (glTF front faces).
            idx.extend((a, c, b, b, c, d))
    if sys.byteorder != "little":
        for arr in (pos, nor, uv, idx):
            arr.byteswap()

    # Textures: contour bands of height (colour) with a grid every 1/64, roughness by band.
    base_rows = []
    palette = [(70, 110, 60), (95, 130, 70), (140, 150, 90), (160, 140, 110), (130, 120, 115),
               (225, 225, 230)]
    for v in range(64):
        row = bytearray()
        for u in range(texture):
            c = palette[(u * 7 // texture + v // 11) % len(palette)]
            row += bytes(c)
        base_rows.append(bytes(row))
    grid_row = bytes((30, 30, 30)) * texture
    line = texture // 64

    def base():
        for y in range(texture):
            if y % line == 0:
                yield grid_row
            else:
                r = bytearray(base_rows[(y * 64 // texture + y // 7) % 64])
                for gx in range(0, texture, line):
                    r[3 * gx:3 * gx + 3] = b"\x1e\x1e\x1e"
                yield bytes(r)
    small = texture // 4
    mr_rows = [bytes((0, 60 + 30 * k, 0)) * small for k in range(6)]

    def metal_rough():
        for y in range(small):
            yield mr_rows[(y * 6) // small]
    images = [png(texture, texture, base()), png(small, small, metal_rough())]

    blob = bytearray()
    views = []

    def view(data, target):
        while len(blob) % 4:
            blob.append(0)
        v = {"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)}
        if target is not None:
            v["target"] = target
        views.append(v)
        blob.extend(data)
        return len(views) - 1

    doc = {
        "asset": {"version": "2.0", "generator": "wavetrace tools/gen_large.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "color": [1.0, 0.95, 0.85], "intensity": 3.0}]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"name": "terrain", "mesh": 0},
            {"name": "sun", "extensions": {"KHR_lights_punctual": {"light": 0}},
             "rotation": quaternion_look(( -0.5, -0.7, -0.4))},
            {"name": "camera", "camera": 0, "translation": [0.0, 0.32, 0.62],
             "rotation": [math.sin(-0.23), 0.0, 0.0, math.cos(-0.23)]},
        ],
        "cameras": [{"type": "perspective",
                     "perspective": {"yfov": 0.8, "aspectRatio": 1.5, "znear": 0.01}}],
        "meshes": [{"name": "terrain", "primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
            "indices": 3, "material": 0}]}],
        "materials": [{"name": "ground", "pbrMetallicRoughness": {
            "baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 1},
            "metallicFactor": 1.0, "roughnessFactor": 1.0}}],
        "textures": [{"source": 0, "sampler": 0}, {"source": 1, "sampler": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9987}],
        "images": [],
        "accessors": [],
        "bufferViews": views,
    }
    doc["accessors"] = [
        {"bufferView": view(pos.tobytes(), ARRAY_BUFFER), "componentType": FLOAT,
         "count": verts * verts, "type": "VEC3",
         "min": [min(pos[0::3]), min(pos[1::3]), min(pos[2::3])],
         "max": [max(pos[0::3]), max(pos[1::3]), max(pos[2::3])]},
        {"bufferView": view(nor.tobytes(), ARRAY_BUFFER), "componentType": FLOAT,
         "count": verts * verts, "type": "VEC3"},
        {"bufferView": view(uv.tobytes(), ARRAY_BUFFER), "componentType": FLOAT,
         "count": verts * verts, "type": "VEC2"},
        {"bufferView": view(idx.tobytes(), ELEMENT_ARRAY_BUFFER), "componentType": UNSIGNED_INT,
         "count": len(idx), "type": "SCALAR"},
    ]
    for k, data in enumerate(images):
        doc["images"].append({"bufferView": view(data, None), "mimeType": "image/png",
                              "name": ["base colour", "metallic-roughness"][k]})
    write_glb_or_gltf(out, doc, blob)


def quaternion_look(d):
    """The rotation turning -Z (a light's direction in glTF) to the unit direction d."""
    x, y, z = d
    length = math.sqrt(x * x + y * y + z * z)
    x, y, z = x / length, y / length, z / length
    # Axis (0, 0, -1) × d = (y, -x, 0), angle acos(-z).
    ax, ay = y, -x
    s = math.sqrt(ax * ax + ay * ay)
    angle = math.acos(max(-1.0, min(1.0, -z)))
    if s < 1e-9:
        return [0.0, 0.0, 0.0, 1.0]
    h = math.sin(angle / 2) / s
    return [ax * h, ay * h, 0.0, math.cos(angle / 2)]


def write_glb_or_gltf(out, doc, blob):
    while len(blob) % 4:
        blob.append(0)
    doc["buffers"] = [{"byteLength": len(blob)}]
    if out.endswith(".glb"):
        text = json.dumps(doc).encode()
        text += b" " * (-len(text) % 4)
        total = 12 + 8 + len(text) + 8 + len(blob)
        with open(out, "wb") as f:
            f.write(struct.pack("<III", 0x46546C67, 2, total))
            f.write(struct.pack("<II", len(text), 0x4E4F534A) + text)
            f.write(struct.pack("<II", len(blob), 0x004E4942))
            f.write(blob)
    else:
        bin_name = out.rsplit("/", 1)[-1].rsplit(".", 1)[0] + ".bin"
        doc["buffers"][0]["uri"] = bin_name
        with open(out, "w", encoding="utf-8") as f:
            json.dump(doc, f)
        with open(out.rsplit(".", 1)[0] + ".bin", "wb") as f:
            f.write(blob)


def read_glb(path):
    data = open(path, "rb").read()
    magic, version, total = struct.unpack_from("<III", data, 0)
    if magic != 0x46546C67 or version != 2:
        sys.exit(f"{path}: not a glTF 2.0 binary")
    offset, doc, blob = 12, None, b""
    while offset < total:
        length, kind = struct.unpack_from("<II", data, offset)
        chunk = data[offset + 8:offset + 8 + length]
        if kind == 0x4E4F534A:
            doc = json.loads(chunk)
        elif kind == 0x004E4942:
            blob = chunk
        offset += 8 + length
    return doc, bytearray(blob)


def helmets(out, helmet, count, keep_emission):
    doc, blob = read_glb(helmet)
    if len(doc.get("meshes", [])) != 1:
        sys.exit(f"{helmet}: expected the DamagedHelmet's one mesh")
    side = math.ceil(math.sqrt(count))
    spacing = 2.2
    # The helmet's own node turns it upright (+Y up, facing +Z); each placement keeps that.
    upright = next(n for n in doc["nodes"] if n.get("mesh") == 0)
    nodes = []
    for k in range(count):
        i, j = k % side, k // side
        x = (i - (side - 1) / 2) * spacing
        z = (j - (side - 1) / 2) * spacing
        node = {"name": f"helmet {k}", "mesh": 0, "translation": [x, 0.0, z]}
        if "rotation" in upright:
            node["rotation"] = upright["rotation"]
        nodes.append(node)
    extent = side * spacing
    # Low over the front row, looking along the grid: near helmets large, the rest receding.
    nodes.append({"name": "camera", "camera": 0,
                  "translation": [0.0, 0.07 * extent, 0.5 * extent + 2.0],
                  "rotation": [math.sin(-0.11), 0.0, 0.0, math.cos(-0.11)]})
    nodes.append({"name": "sun", "extensions": {"KHR_lights_punctual": {"light": 0}},
                  "rotation": quaternion_look((0.3, -0.8, -0.5))})
    doc["nodes"] = nodes
    doc["scenes"] = [{"nodes": list(range(len(nodes)))}]
    doc["scene"] = 0
    doc["cameras"] = [{"type": "perspective",
                       "perspective": {"yfov": 0.7, "aspectRatio": 1.5, "znear": 0.05}}]
    doc.setdefault("extensions", {})["KHR_lights_punctual"] = {"lights": [
        {"type": "directional", "color": [1.0, 0.96, 0.9], "intensity": 3.0}]}
    used = set(doc.get("extensionsUsed", [])) | {"KHR_lights_punctual"}
    doc["extensionsUsed"] = sorted(used)
    if not keep_emission:
        # wavetrace bakes every placement of an emitting mesh into world space (its emitter
        # table samples world-space triangles), which would store 1000 copies of the helmet.
        for m in doc.get("materials", []):
            m.pop("emissiveTexture", None)
            m.pop("emissiveFactor", None)
    doc.pop("animations", None)
    doc.pop("skins", None)
    doc["asset"]["generator"] = "wavetrace tools/gen_large.py from " + doc["asset"].get("generator", "?")
    write_glb_or_gltf(out, doc, blob)
    print(f"helmets: {count} placements on a {side} x {side} grid", file=sys.stderr)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="scene", required=True)
    t = sub.add_parser("terrain")
    t.add_argument("out")
    t.add_argument("--triangles", type=int, default=5_000_000)
    t.add_argument("--texture", type=int, default=8192)
    h = sub.add_parser("helmets")
    h.add_argument("out")
    h.add_argument("--helmet", required=True)
    h.add_argument("--count", type=int, default=1000)
    h.add_argument("--keep-emission", action="store_true",
                   help="keep the visor's emissive texture (every placement is then baked)")
    a = p.parse_args()
    if a.scene == "terrain":
        if a.texture < 64 or a.texture % 64:
            sys.exit("--texture must be a multiple of 64")
        terrain(a.out, a.triangles, a.texture)
    else:
        helmets(a.out, a.helmet, a.count, a.keep_emission)


if __name__ == "__main__":
    main()
