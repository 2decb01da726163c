#!/usr/bin/env python3
"""Renders a wavetrace scene with Mitsuba 3 and prints its samples/s, for the side-by-side
speed figures of `wavetrace bench` (issue: CPU reference against Mitsuba's scalar_rgb, the GPU
path against llvm_ad_rgb / cuda_ad_rgb).

    pip install mitsuba
    python3 tools/mitsuba_bench.py scenes/cornell-box.gltf [--variant scalar_rgb]
        [--width 256] [--height 256] [--spp 16] [--max-depth 8] [--rr-depth 3] [--out FILE.exr]
        [--threads N]

The glTF file is converted, not approximated: only what both renderers mean the same by is
accepted — triangle meshes (node matrices or TRS, any hierarchy), materials that are exactly
Lambertian in wavetrace (metallicFactor 0 and KHR_materials_specular specularFactor 0: base
colour factor only, no textures), emission (emissiveFactor × KHR_materials_emissive_strength,
from the front face) and a perspective camera. Anything else is refused with its name. One
difference stays: where doubleSided is false wavetrace culls back faces and Mitsuba's one-sided
diffuse shows them black, so the two images agree where no back face is seen (a closed room
from inside, as the Cornell box; doubleSided true becomes Mitsuba's twosided). The meshes go to
temporary binary PLY files.

Settings are matched to `wavetrace render`'s: --max-depth bounces (Mitsuba's max_depth counts
path segments, so it gets one more), Russian roulette from the same vertex (--rr-depth, the
scattering events before it; Mitsuba's survival probability is min(max throughput, 0.95),
wavetrace's min(max throughput, 1)), a box pixel filter, independent samples. The timed render
follows an untimed one at 1 spp (LLVM variants compile their kernels there). --out writes the
timed image, to compare with a wavetrace render of the same settings (`--sampler independent`).

On the project's 2-core machine (2 December 2026, Mitsuba 3.9.1 from pip) scalar_rgb runs; the
llvm_ad_rgb variant stops in LLVM's instruction selection (a 16-wide vselect) while compiling
its first kernel, so no LLVM figure is printed there.

Python 3 standard library and the mitsuba wheel only.
"""

import argparse
import base64
import json
import math
import os
import struct
import sys
import tempfile
import time


def fail(path, what):
    sys.exit(f"{path}: {what}")


def mat_mul(a, b):
    """4×4 row-major product."""
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def node_matrix(node):
    """A glTF node's local matrix, row-major."""
    if "matrix" in node:
        m = node["matrix"]  # column-major
        return [[m[c * 4 + r] for c in range(4)] for r in range(4)]
    tx, ty, tz = node.get("translation", [0, 0, 0])
    qx, qy, qz, qw = node.get("rotation", [0, 0, 0, 1])
    sx, sy, sz = node.get("scale", [1, 1, 1])
    r = [
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
        [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
        [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
    ]
    return [
        [r[0][0] * sx, r[0][1] * sy, r[0][2] * sz, tx],
        [r[1][0] * sx, r[1][1] * sy, r[1][2] * sz, ty],
        [r[2][0] * sx, r[2][1] * sy, r[2][2] * sz, tz],
        [0, 0, 0, 1],
    ]


def load_gltf(path):
    """The JSON and its buffers (.gltf with data: or relative URIs; .glb)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] == b"glTF":
        length = struct.unpack_from("<I", data, 12)[0]
        doc = json.loads(data[20 : 20 + length])
        offset = 20 + length
        bin_chunk = data[offset + 8 :] if offset < len(data) else b""
        buffers = [bin_chunk]
        return doc, buffers
    doc = json.loads(data)
    buffers = []
    for b in doc.get("buffers", []):
        uri = b.get("uri", "")
        if uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            with open(os.path.join(os.path.dirname(path), uri), "rb") as f:
                buffers.append(f.read())
    return doc, buffers


COMPONENTS = {5121: ("B", 1), 5123: ("H", 2), 5125: ("I", 4), 5126: ("f", 4)}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def read_accessor(path, doc, buffers, index):
    acc = doc["accessors"][index]
    if "sparse" in acc or "bufferView" not in acc:
        fail(path, f"accessor {index}: sparse or bufferless accessors are not converted")
    view = doc["bufferViews"][acc["bufferView"]]
    fmt, size = COMPONENTS[acc["componentType"]]
    width = WIDTH[acc["type"]]
    stride = view.get("byteStride", size * width)
    base = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    buf = buffers[view["buffer"]]
    return [
        struct.unpack_from("<" + fmt * width, buf, base + k * stride) for k in range(acc["count"])
    ]


def lambertian_colour(path, doc, index):
    """The base colour of a material wavetrace renders exactly Lambertian; else refuses it."""
    m = doc["materials"][index]
    name = m.get("name", f"material {index}")
    pbr = m.get("pbrMetallicRoughness", {})
    specular = m.get("extensions", {}).get("KHR_materials_specular", {})
    if pbr.get("metallicFactor", 1.0) != 0.0 or specular.get("specularFactor", 1.0) != 0.0:
        fail(path, f"{name}: not exactly Lambertian (needs metallicFactor 0 and specularFactor 0)")
    if "baseColorTexture" in pbr or "emissiveTexture" in m:
        fail(path, f"{name}: textures are not converted")
    known = {"KHR_materials_specular", "KHR_materials_emissive_strength"}
    for ext in m.get("extensions", {}):
        if ext not in known:
            fail(path, f"{name}: {ext} is not converted")
    colour = pbr.get("baseColorFactor", [1, 1, 1, 1])[:3]
    strength = m.get("extensions", {}).get("KHR_materials_emissive_strength", {})
    emission = [e * strength.get("emissiveStrength", 1.0) for e in m.get("emissiveFactor", [0, 0, 0])]
    return colour, emission, m.get("doubleSided", False)


def write_ply(file, positions, faces):
    with open(file, "wb") as f:
        f.write(
            (
                "ply\nformat binary_little_endian 1.0\n"
                f"element vertex {len(positions)}\nproperty float x\nproperty float y\nproperty float z\n"
                f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
            ).encode()
        )
        for p in positions:
            f.write(struct.pack("<3f", *p))
        for a, b, c in faces:
            f.write(struct.pack("<B3i", 3, a, b, c))


def scene_dict(path, args, folder):
    """The Mitsuba scene of a glTF file (see the module docs for what converts)."""
    doc, buffers = load_gltf(path)
    for ext in doc.get("extensionsRequired", []):
        fail(path, f"requires {ext}, which is not converted")
    scene = {"type": "scene"}
    camera = None
    count = 0

    def visit(index, parent):
        nonlocal camera, count
        node = doc["nodes"][index]
        world = mat_mul(parent, node_matrix(node))
        if "camera" in node and camera is None:
            camera = (doc["cameras"][node["camera"]], world)
        if "extensions" in node:
            fail(path, f"node {node.get('name', index)}: {', '.join(node['extensions'])} not converted")
        if "mesh" in node:
            mesh = doc["meshes"][node["mesh"]]
            for k, prim in enumerate(mesh["primitives"]):
                if prim.get("mode", 4) != 4:
                    fail(path, f"{mesh.get('name', node['mesh'])}: only triangle lists convert")
                positions = read_accessor(path, doc, buffers, prim["attributes"]["POSITION"])
                if "indices" in prim:
                    flat = [i[0] for i in read_accessor(path, doc, buffers, prim["indices"])]
                else:
                    flat = list(range(len(positions)))
                faces = [tuple(flat[i : i + 3]) for i in range(0, len(flat) - 2, 3)]
                world_positions = [
                    tuple(sum(world[r][c] * (list(p) + [1.0])[c] for c in range(4)) for r in range(3))
                    for p in positions
                ]
                if "material" not in prim:
                    fail(path, f"{mesh.get('name', node['mesh'])}: the default material is not Lambertian")
                colour, emission, two_sided = lambertian_colour(path, doc, prim["material"])
                file = os.path.join(folder, f"mesh{count}.ply")
                write_ply(file, world_positions, faces)
                shape = {
                    "type": "ply",
                    "filename": file,
                    "face_normals": True,
                    "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": colour}},
                }
                if two_sided:
                    shape["bsdf"] = {"type": "twosided", "bsdf": shape["bsdf"]}
                if any(e > 0 for e in emission):
                    shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": emission}}
                scene[f"mesh{count}"] = shape
                count += 1
        for child in node.get("children", []):
            visit(child, world)

    identity = [[float(i == j) for j in range(4)] for i in range(4)]
    roots = doc["scenes"][doc.get("scene", 0)]["nodes"]
    for root in roots:
        visit(root, identity)
    if camera is None:
        fail(path, "no camera node")
    cam, world = camera
    if cam["type"] != "perspective":
        fail(path, "only perspective cameras convert")
    # glTF cameras look down -Z with +X right; Mitsuba's down +Z with +X left: turn half-way
    # about Y.
    flip = [[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]]
    to_world = mat_mul(world, flip)
    import mitsuba as mi

    scene["sensor"] = {
        "type": "perspective",
        "fov_axis": "y",
        "fov": math.degrees(cam["perspective"]["yfov"]),
        "to_world": mi.ScalarTransform4f(to_world),
        "film": {
            "type": "hdrfilm",
            "width": args.width,
            "height": args.height,
            "rfilter": {"type": "box"},
            "pixel_format": "rgb",
        },
        "sampler": {"type": "independent", "sample_count": args.spp},
    }
    scene["integrator"] = {
        "type": "path",
        "max_depth": args.max_depth + 1,
        # Mitsuba starts roulette at path depth rr_depth (1 = the first scattering event).
        "rr_depth": args.rr_depth,
    }
    return scene


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--width", type=int, default=256)
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--rr-depth", type=int, default=3)
    ap.add_argument("--out")
    ap.add_argument("--threads", type=int, help="render threads (default: every core)")
    args = ap.parse_args()
    import mitsuba as mi

    mi.set_variant(args.variant)
    if args.threads:
        import drjit as dr

        dr.set_thread_count(args.threads)
    with tempfile.TemporaryDirectory() as folder:
        scene = mi.load_dict(scene_dict(args.scene, args, folder))
        mi.render(scene, spp=1)  # untimed: LLVM variants compile their kernels here
        start = time.perf_counter()
        image = mi.render(scene, spp=args.spp, seed=1)
        if hasattr(image, "numpy") or args.variant != "scalar_rgb":
            import drjit as dr

            dr.eval(image)
            dr.sync_thread()
        seconds = time.perf_counter() - start
    samples = args.width * args.height * args.spp
    print(
        f"{os.path.basename(args.scene)}: Mitsuba {mi.__version__} {args.variant}, "
        f"{args.width}×{args.height} at {args.spp} spp, max depth {args.max_depth}: "
        f"{seconds:.3f} s, {samples / seconds * 1e-6:.3f} M samples/s"
    )
    if args.out:
        mi.util.write_bitmap(args.out, image)
        print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
