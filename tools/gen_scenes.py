#!/usr/bin/env python3
"""Writes the committed test scenes as self-contained glTF 2.0 files (base64 data: buffers).

    python3 tools/gen_scenes.py           # writes every scene into scenes/
    python3 tools/gen_scenes.py OUT_DIR   # writes them into OUT_DIR instead

Output is deterministic (same bytes on every run). Python 3 standard library only.

Lambertian materials are Lambertian in glTF's own terms, not only in wavetrace's: metallicFactor
0, roughnessFactor 1 and KHR_materials_specular's specularFactor 0, which removes the dielectric
specular lobe of the metallic-roughness BSDF and leaves only the diffuse term baseColor / pi
(listed in extensionsUsed, not extensionsRequired: a viewer that ignores it shows a slightly
glossy version of the same scene). Emitted radiance is emissiveFactor (max component 1) times
KHR_materials_emissive_strength.

- cornell-box.gltf: the Cornell box of Mitsuba/pbrt test scenes, built from unit primitives
  (rectangle [-1,1]^2 in local XY with normal +Z; cube [-1,1]^3 with outward normals) placed by
  node matrices. All Lambertian; the light emits radiance (18.387, 13.9873, 6.75357) from its
  front face.
- cornell-materials.gltf: the same box and light, the tall box rough copper (metallicFactor 1,
  roughnessFactor 0.3) and, in place of the short box, a smooth glass sphere (radius 0.3,
  KHR_materials_transmission 1, KHR_materials_ior 1.5) resting on the floor.
- instances.gltf: 1000 placements of two meshes stored once (600 nodes sharing a copper
  icosphere, 400 glass cubes through EXT_mesh_gpu_instancing), with rotations, non-uniform
  scales and mirroring, on a floor under a square light.
- furnace.gltf: a closed unit icosphere (subdivision 3, watertight) facing inwards with albedo
  0.5 and emission 0.5, camera at the centre: the exact radiance everywhere is
  Le / (1 - a) = 1.
- veach-mis.gltf: the multiple importance sampling test of Veach & Guibas 1995 (Veach's thesis,
  fig. 9.2), see veach_mis().
- many-lights.gltf: 10,240 small emissive triangles of 16 colours and strengths in a canopy
  above a floor with a few diffuse boxes, for many-light sampling, see many_lights().
- leaf.gltf: a leaf lit from behind (KHR_materials_diffuse_transmission), see leaf().
- prism.gltf: a dispersive glass prism (KHR_materials_dispersion) showing a white slit's
  spectrum, see prism().
"""

import base64
import json
import math
import os
import random
import re
import struct
import sys

FLOAT, UNSIGNED_SHORT = 5126, 5123
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


# ---------------------------------------------------------------------------------------------
# Geometry

def rectangle():
    """Square [-1,1]^2 at z = 0, counter-clockwise seen from +Z (normal +Z)."""
    positions = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    return positions, [(0, 1, 2), (0, 2, 3)]


def cube():
    """Cube [-1,1]^3 with 8 shared vertices, every face counter-clockwise seen from outside."""
    positions = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
    index = {p: i for i, p in enumerate(positions)}
    triangles = []
    for axis in range(3):
        for sign in (1, -1):
            n = [0, 0, 0]
            n[axis] = sign
            # Tangents u, v with u x v = n.
            u = [0, 0, 0]
            v = [0, 0, 0]
            u[(axis + 1) % 3] = 1
            v[(axis + 2) % 3] = sign
            corners = []
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                corners.append(index[tuple(n[k] + a * u[k] + b * v[k] for k in range(3))])
            triangles += [(corners[0], corners[1], corners[2]), (corners[0], corners[2], corners[3])]
    check_winding(positions, triangles, lambda centroid: centroid)
    return positions, triangles


def icosphere(subdivisions):
    """Unit icosphere with shared vertices, every triangle counter-clockwise seen from outside."""
    t = (1 + math.sqrt(5)) / 2
    positions = [normalize(p) for p in [
        (-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
        (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
        (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]]
    # Counter-clockwise seen from outside.
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
             (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
             (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
             (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        midpoint_of = {}

        def midpoint(a, b):
            key = (min(a, b), max(a, b))
            if key not in midpoint_of:
                pa, pb = positions[a], positions[b]
                positions.append(normalize(tuple((pa[k] + pb[k]) / 2 for k in range(3))))
                midpoint_of[key] = len(positions) - 1
            return midpoint_of[key]

        refined = []
        for a, b, c in faces:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            refined += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = refined
    check_winding(positions, faces, lambda centroid: centroid)
    return positions, faces


def inside_out(positions, triangles):
    """The same surface, star-shaped about the origin, facing the other way (windings reversed)."""
    flipped = [(a, c, b) for a, b, c in triangles]
    check_winding(positions, flipped, lambda centroid: tuple(-x for x in centroid))
    return positions, flipped


def surface_area(positions, triangles):
    total = 0.0
    for a, b, c in triangles:
        n = cross(sub(positions[b], positions[a]), sub(positions[c], positions[a]))
        total += 0.5 * math.sqrt(sum(x * x for x in n))
    return total


def sub(p, q):
    return tuple(p[k] - q[k] for k in range(3))


def cross(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def normalize(p):
    length = math.sqrt(sum(x * x for x in p))
    return tuple(x / length for x in p)


def check_winding(positions, triangles, outward_of):
    """Asserts that every geometric normal points along outward_of(centroid)."""
    for tri in triangles:
        p0, p1, p2 = (positions[i] for i in tri)
        n = cross(sub(p1, p0), sub(p2, p0))
        centroid = tuple(sum(positions[i][k] for i in tri) / 3 for k in range(3))
        direction = outward_of(centroid)
        assert sum(n[k] * direction[k] for k in range(3)) > 0, tri


# ---------------------------------------------------------------------------------------------
# glTF assembly

class Gltf:
    """Accumulates one binary buffer and the JSON objects that point into it."""

    def __init__(self):
        self.blob = bytearray()
        self.doc = {
            "asset": {"version": "2.0", "generator": "wavetrace tools/gen_scenes.py"},
            "scene": 0,
            "scenes": [{"nodes": []}],
            "nodes": [], "meshes": [], "materials": [], "cameras": [],
            "accessors": [], "bufferViews": [], "buffers": [],
        }

    def _view(self, data, target):
        while len(self.blob) % 4:
            self.blob.append(0)
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        self.doc["bufferViews"].append(view)
        self.blob += data
        return len(self.doc["bufferViews"]) - 1

    def geometry(self, positions, triangles):
        """Adds position and index accessors; returns the primitive's attribute dictionary."""
        flat = [float(x) for p in positions for x in p]
        view = self._view(struct.pack("<%df" % len(flat), *flat), ARRAY_BUFFER)
        stored = [struct.unpack("<f", struct.pack("<f", x))[0] for x in flat]
        self.doc["accessors"].append({
            "bufferView": view, "componentType": FLOAT, "count": len(positions), "type": "VEC3",
            "min": [min(stored[k::3]) for k in range(3)],
            "max": [max(stored[k::3]) for k in range(3)]})
        indices = [i for tri in triangles for i in tri]
        view = self._view(struct.pack("<%dH" % len(indices), *indices), ELEMENT_ARRAY_BUFFER)
        self.doc["accessors"].append(
            {"bufferView": view, "componentType": UNSIGNED_SHORT, "count": len(indices), "type": "SCALAR"})
        n = len(self.doc["accessors"])
        return {"attributes": {"POSITION": n - 2}, "indices": n - 1}

    def material(self, name, base_color, emissive=None, strength=None, metallic=0.0, roughness=1.0,
                 extensions=None):
        """Adds a material; `extensions` maps extension names to their objects."""
        material = {
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": list(base_color) + [1.0], "metallicFactor": float(metallic),
                "roughnessFactor": float(roughness)},
            "doubleSided": False,
        }
        if emissive is not None:
            material["emissiveFactor"] = list(emissive)
        extensions = dict(extensions or {})
        if strength is not None:
            extensions["KHR_materials_emissive_strength"] = {"emissiveStrength": strength}
        if extensions:
            material["extensions"] = dict(sorted(extensions.items()))
            used = set(self.doc.get("extensionsUsed", [])) | set(extensions)
            self.doc["extensionsUsed"] = sorted(used)
        self.doc["materials"].append(material)
        return len(self.doc["materials"]) - 1

    def lambertian(self, name, base_color, emissive=None, strength=None):
        """A purely diffuse material in glTF's terms: no metal, no dielectric specular lobe."""
        return self.material(name, base_color, emissive, strength,
                             extensions={"KHR_materials_specular": {"specularFactor": 0.0}})

    def mesh(self, name, geometry, material):
        self.doc["meshes"].append({"name": name, "primitives": [dict(geometry, material=material)]})
        return len(self.doc["meshes"]) - 1

    def node(self, node):
        self.doc["nodes"].append(node)
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def camera(self, name, yfov, translation, aspect_ratio=1.0, pitch=0.0):
        """A perspective camera looking down -Z, turned up by `pitch` radians about +X."""
        self.doc["cameras"].append({"name": name, "type": "perspective", "perspective": {
            "yfov": yfov, "aspectRatio": aspect_ratio, "znear": 0.01}})
        node = {"name": name, "camera": len(self.doc["cameras"]) - 1}
        if pitch:
            node["rotation"] = [math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2)]
        if translation is not None:
            node["translation"] = list(translation)
        self.node(node)

    def write(self, path):
        uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.blob)).decode("ascii")
        self.doc["buffers"] = [{"byteLength": len(self.blob), "uri": uri}]
        text = json.dumps(self.doc, indent=1)
        # Numeric arrays (matrices, factors, bounds) on one line each.
        text = re.sub(r"\[\s*([-+0-9.eE,\s]+?)\s*\]",
                      lambda m: "[" + ", ".join(x.strip() for x in m.group(1).split(",")) + "]", text)
        with open(path, "w", encoding="utf-8", newline="\n") as f:
            f.write(text + "\n")


def column_major(rows):
    """Row-major 3x4 [R | t] -> glTF's column-major 4x4 `matrix`."""
    matrix = []
    for c in range(4):
        matrix += [float(rows[r][c]) for r in range(3)] + [1.0 if c == 3 else 0.0]
    return matrix


# ---------------------------------------------------------------------------------------------
# Scenes

# The Cornell box's boxes as [R | t] rows placing the unit cube.
TALL_BOX = [[0.28491, 0, 0.0939491, -0.33], [0, 0.61, 0, -0.4], [-0.0939491, 0, 0.28491, -0.28]]
SHORT_BOX = [[0.286891, 0, -0.0877115, 0.335], [0, 0.3, 0, -0.7], [0.0877115, 0, 0.286891, 0.38]]


def cornell_room(g, add_contents):
    """The Cornell box's walls and light, `add_contents(g, white)` in between, then the camera."""
    white = g.lambertian("white", (0.885809, 0.698859, 0.666422))
    red = g.lambertian("red", (0.570068, 0.0430135, 0.0443706))
    green = g.lambertian("green", (0.105421, 0.37798, 0.076425))
    radiance = (18.387, 13.9873, 6.75357)
    peak = max(radiance)
    light = g.lambertian("light", (0.885809, 0.698859, 0.666422), [c / peak for c in radiance], peak)

    rect = g.geometry(*rectangle())
    meshes = {
        "white rectangle": g.mesh("white rectangle", rect, white),
        "red rectangle": g.mesh("red rectangle", rect, red),
        "green rectangle": g.mesh("green rectangle", rect, green),
        "light rectangle": g.mesh("light rectangle", rect, light),
    }
    shapes = [
        ("floor", "white rectangle", [[1, 0, 0, 0], [0, 0, 1, -1], [0, -1, 0, 0]]),
        ("ceiling", "white rectangle", [[1, 0, 0, 0], [0, 0, -1, 1], [0, 1, 0, 0]]),
        ("back wall", "white rectangle", [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -1]]),
        ("green wall", "green rectangle", [[0, 0, -1, 1], [0, 1, 0, 0], [1, 0, 0, 0]]),
        ("red wall", "red rectangle", [[0, 0, 1, -1], [0, 1, 0, 0], [-1, 0, 0, 0]]),
        ("light", "light rectangle", [[0.23, 0, 0, 0], [0, 0, -0.19, 0.99], [0, 0.19, 0, 0.01]]),
    ]
    for name, mesh, rows in shapes:
        g.node({"name": name, "mesh": meshes[mesh], "matrix": column_major(rows)})
    add_contents(g, white)
    g.camera("camera", math.radians(39.3077), (0.0, 0.0, 3.9))
    return g


def cornell_box():
    def boxes(g, white):
        cube_mesh = g.mesh("white cube", g.geometry(*cube()), white)
        for name, rows in (("tall box", TALL_BOX), ("short box", SHORT_BOX)):
            g.node({"name": name, "mesh": cube_mesh, "matrix": column_major(rows)})
    return cornell_room(Gltf(), boxes)


def cornell_materials():
    def metal_and_glass(g, _white):
        # Copper's F0 (linear sRGB) as base colour; alpha = roughness^2 = 0.09 in glTF's GGX.
        copper = g.material("rough copper", (0.95, 0.64, 0.54), metallic=1.0, roughness=0.3)
        g.node({"name": "tall box", "mesh": g.mesh("copper cube", g.geometry(*cube()), copper),
                "matrix": column_major(TALL_BOX)})
        # Solid glass: KHR_materials_volume makes the sphere the boundary of a medium (without
        # it glTF's transmission is thin-walled, a soap bubble); thicknessFactor is the diameter.
        glass = g.material("glass", (1.0, 1.0, 1.0), metallic=0.0, roughness=0.0, extensions={
            "KHR_materials_transmission": {"transmissionFactor": 1.0},
            "KHR_materials_ior": {"ior": 1.5},
            "KHR_materials_volume": {"thicknessFactor": 0.6}})
        positions, triangles = icosphere(3)
        # Centred over the short box's footprint, its lowest vertex on the floor (y = -1).
        radius = 0.3
        x, z = SHORT_BOX[0][3], SHORT_BOX[2][3]
        y = -1.0 - radius * min(p[1] for p in positions)
        sphere = g.mesh("glass sphere", g.geometry(positions, triangles), glass)
        g.node({"name": "glass sphere", "mesh": sphere,
                "matrix": column_major([[radius, 0, 0, x], [0, radius, 0, y], [0, 0, radius, z]])})
    return cornell_room(Gltf(), metal_and_glass)


def furnace():
    g = Gltf()
    material = g.lambertian("furnace", (0.5, 0.5, 0.5), (0.5, 0.5, 0.5))
    sphere = g.mesh("sphere", g.geometry(*inside_out(*icosphere(3))), material)
    g.node({"name": "sphere", "mesh": sphere})
    g.camera("camera", math.radians(60.0), None)
    return g


# Veach's MIS scene: camera, light row and plates (plate 0 nearest the camera and lowest).
VEACH_CAMERA = (0.0, 5.0, 11.0)
VEACH_LIGHT_ROW = (4.5, -0.5)
VEACH_LIGHTS = [(-3.6, 0.03), (-1.2, 0.1), (1.2, 0.3), (3.6, 0.9)]
VEACH_PLATES = [((0.0, 0.0, 4.0), 0.35), ((0.0, 0.6, 2.6), 0.2), ((0.0, 1.2, 1.2), 0.1),
                ((0.0, 1.8, -0.2), 0.05)]
VEACH_PLATE_SIZE = (8.0, 1.0)


def veach_mis():
    """The glossy plates of Veach & Guibas 1995 (Veach's thesis, fig. 9.2), rebuilt from the text.

    Four spherical lights in a row (x = -3.6 .. 3.6, y = 4.5, z = -0.5) with radii 0.03, 0.1, 0.3
    and 0.9 and equal power: a sphere of radiance L and radius r emits 4 pi^2 r^2 L, so
    L = 1 / r^2 gives each 4 pi^2 W (corrected for the area of the triangulated sphere, 1-3 %
    below 4 pi r^2). The lights are black and purely diffuse: they reflect nothing.

    Four 8 x 1 plates of glossy metal (metallicFactor 1, base colour 0.7) stand like steps in
    front of them, roughness 0.35, 0.2, 0.1 and 0.05 (GGX alpha = roughness^2) from the nearest,
    lowest plate to the farthest, highest one, as in the original, where the top plate is the
    most mirror-like. Each plate's normal is the half vector between the directions from its
    centre to the camera and to the middle of the light row, so the camera sees every light
    mirrored near the plate's middle line, at x = x_light * d_camera / (d_camera + d_light)
    (|x| < 3 here, inside the plate); the steps are spaced so that no plate blocks another's
    mirror paths. No backdrop: the background is black unless --environment says otherwise.
    """
    g = Gltf()
    rect = g.geometry(*rectangle())
    for i, (centre, roughness) in enumerate(VEACH_PLATES):
        metal = g.material("plate %d roughness %g" % (i, roughness), (0.7, 0.7, 0.7),
                           metallic=1.0, roughness=roughness)
        to_camera = normalize(tuple(VEACH_CAMERA[k] - centre[k] for k in range(3)))
        to_lights = normalize((0.0, VEACH_LIGHT_ROW[0] - centre[1], VEACH_LIGHT_ROW[1] - centre[2]))
        n = normalize(tuple(to_camera[k] + to_lights[k] for k in range(3)))
        # Local X stays world X (the plate's length); local Y goes to t = n x X, so local +Z
        # (the rectangle's front) goes to n with a proper rotation.
        t = (0.0, n[2], -n[1])
        half_length, half_depth = VEACH_PLATE_SIZE[0] / 2, VEACH_PLATE_SIZE[1] / 2
        rows = [[half_length * (r == 0), half_depth * t[r], n[r], centre[r]] for r in range(3)]
        g.node({"name": "plate %d" % i, "mesh": g.mesh("plate %d" % i, rect, metal),
                "matrix": column_major(rows)})
    spheres = {n: icosphere(n) for n in (2, 3)}
    geometries = {n: g.geometry(*sphere) for n, sphere in spheres.items()}
    for i, (x, radius) in enumerate(VEACH_LIGHTS):
        # Subdivision 3 (1280 triangles) where the sphere is large enough to show facets.
        n = 3 if radius >= 0.3 else 2
        # Radiance 4 pi / (mesh area): every triangulated light emits exactly 4 pi^2 W.
        strength = float("%.9g" % (4 * math.pi / (surface_area(*spheres[n]) * radius ** 2)))
        light = g.lambertian("light %d radius %g" % (i, radius), (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), strength)
        y, z = VEACH_LIGHT_ROW
        g.node({"name": "light %d" % i, "mesh": g.mesh("light %d" % i, geometries[n], light),
                "matrix": column_major([[radius, 0, 0, x], [0, radius, 0, y], [0, 0, radius, z]])})
    g.camera("camera", math.radians(44.0), VEACH_CAMERA, aspect_ratio=1.6, pitch=math.radians(-17.5))
    return g


def instances():
    """1000 placements of two meshes stored once: 600 nodes share a rough-copper icosphere
    (subdivision 3, 1280 triangles) and a node with EXT_mesh_gpu_instancing places 400 glass
    cubes (KHR_materials_transmission). Rotations, non-uniform scales and mirroring (negative
    determinants, every third placement) exercise the instance transforms; a floor and a square
    light are baked. Flattened, the placements would be 600 * 1280 + 400 * 12 = 772,800
    triangles; the loader stores 1280 + 12 + 4.
    """
    g = Gltf()
    white = g.lambertian("floor", (0.6, 0.6, 0.6))
    light = g.lambertian("light", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 12.0)
    copper = g.material("rough copper", (0.95, 0.64, 0.54), metallic=1.0, roughness=0.4)
    # Solid glass cubes (KHR_materials_volume; thicknessFactor: the unit cube's edge).
    glass = g.material("glass", (0.9, 1.0, 0.95), metallic=0.0, roughness=0.1, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0},
        "KHR_materials_volume": {"thicknessFactor": 1.0}})
    rect = g.geometry(*rectangle())
    # The floor: the unit rectangle (z = 0, front +Z) turned to face +Y and scaled to 24 x 24.
    g.node({"name": "floor", "mesh": g.mesh("floor", rect, white),
            "matrix": column_major([[12, 0, 0, 0], [0, 0, 12, 0], [0, -12, 0, 0]])})
    # The light: facing down (-Y) at y = 9.
    g.node({"name": "light", "mesh": g.mesh("light", rect, light),
            "matrix": column_major([[3, 0, 0, 0], [0, 0, -3, 9], [0, 3, 0, 0]])})
    sphere = g.mesh("copper sphere", g.geometry(*icosphere(3)), copper)
    for k in range(600):
        i, j = k % 30, k // 30
        x, z = -9.5 + i * 0.65, -9.5 + j * 0.95
        r = 0.18 + 0.1 * ((k * 7) % 5) / 4
        sx = -r if k % 3 == 0 else r
        angle = 0.3 * k
        c, s_ = math.cos(angle), math.sin(angle)
        # Rotation about Y, then a non-uniform scale (squashed in y), mirrored in x every third.
        rows = [[sx * c, 0, s_ * r, x], [0, 0.7 * r, 0, 0.7 * r], [-sx * s_, 0, c * r, z]]
        g.node({"name": "sphere %d" % k, "mesh": sphere, "matrix": column_major(rows)})
    cube_mesh = g.mesh("glass cube", g.geometry(*cube()), glass)
    translations, rotations, scales = [], [], []
    for k in range(400):
        i, j = k % 20, k // 20
        half = 0.12 + 0.05 * (k % 4)
        translations += [-9.0 + i * 0.95, 2.2 + 0.3 * (k % 3), -9.0 + j * 0.95]
        angle = 0.45 * k
        rotations += [0.0, math.sin(angle / 2), 0.0, math.cos(angle / 2)]
        scales += [-half if k % 3 == 1 else half, half, half]
    views = []
    for values in (translations, rotations, scales):
        views.append(g._view(struct.pack("<%df" % len(values), *values), None))
    for view, kind, count in zip(views, ("VEC3", "VEC4", "VEC3"), (400, 400, 400)):
        g.doc["accessors"].append({"bufferView": view, "componentType": FLOAT, "count": count,
                                   "type": kind})
    n = len(g.doc["accessors"])
    g.node({"name": "glass cubes", "mesh": cube_mesh, "extensions": {"EXT_mesh_gpu_instancing": {
        "attributes": {"TRANSLATION": n - 3, "ROTATION": n - 2, "SCALE": n - 1}}}})
    used = set(g.doc.get("extensionsUsed", [])) | {"EXT_mesh_gpu_instancing"}
    g.doc["extensionsUsed"] = sorted(used)
    g.camera("camera", math.radians(50.0), (0.0, 9.0, 14.0), aspect_ratio=1.5, pitch=math.radians(-35.0))
    return g


def caustic():
    """A glass sphere on a diffuse floor under a small light: the caustic scene of the
    bidirectional tests. The sphere (radius 1, icosphere subdivision 4 with smooth normals
    absent, so facets refract; KHR_materials_transmission 1, ior 1.5, roughness 0: a delta
    dielectric) rests on a 12 x 12 white floor with a white back wall; a 0.1 x 0.1 light faces
    down at y = 5, 1.5 to the side of the sphere, so the focused LS+DE caustic lands on the floor
    beside the sphere's shadow. Path tracing finds it only by BSDF-sampled rays hitting the
    small light through the sphere; light tracing and BDPT connect it to the eye directly.
    """
    g = Gltf()
    white = g.lambertian("white", (0.75, 0.75, 0.75))
    light = g.lambertian("light", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 3600.0)
    # Solid glass (KHR_materials_volume; thicknessFactor: the diameter).
    glass = g.material("glass", (1.0, 1.0, 1.0), metallic=0.0, roughness=0.0, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5},
        "KHR_materials_volume": {"thicknessFactor": 2.0}})
    rect = g.geometry(*rectangle())
    g.node({"name": "floor", "mesh": g.mesh("floor", rect, white),
            "matrix": column_major([[6, 0, 0, 0], [0, 0, 6, 0], [0, -6, 0, 0]])})
    g.node({"name": "back wall", "mesh": g.mesh("back wall", rect, white),
            "matrix": column_major([[6, 0, 0, 0], [0, 6, 0, 6], [0, 0, 1, -4]])})
    g.node({"name": "light", "mesh": g.mesh("light", rect, light),
            "matrix": column_major([[0.05, 0, 0, -1.5], [0, 0, -0.05, 5], [0, 0.05, 0, 0]])})
    g.node({"name": "glass sphere", "mesh": g.mesh("glass sphere", g.geometry(*icosphere(4)), glass),
            "matrix": column_major([[1, 0, 0, 0.4], [0, 1, 0, 1], [0, 0, 1, 0]])})
    g.camera("camera", math.radians(36.0), (0.6, 3.2, 6.0), aspect_ratio=1.0, pitch=math.radians(-28.0))
    return g


# The many-light canopy: a grid of emitter cells over the floor and the emitters' palette.
MANY_LIGHTS_GRID = (128, 80)
MANY_LIGHTS_AREA = ((-8.0, 8.0), (-7.0, 3.0))
MANY_LIGHTS_COLOURS = [(1.0, 0.82, 0.55), (0.55, 0.75, 1.0), (1.0, 0.32, 0.22), (0.35, 1.0, 0.42)]
MANY_LIGHTS_STRENGTHS = [1.5, 4.0, 10.0, 25.0]


def many_lights():
    """10,240 small emissive triangles for many-light sampling: one per cell of a 128 x 80 grid
    over x in [-8, 8], z in [-7, 3], at heights 2.2-3.8 on a gentle wave, jittered in the cell.
    Each is an equilateral triangle of side 0.06-0.16 whose front face (the emitting side) looks
    down, tilted up to 50 degrees from straight down; one in ten faces up instead, towards no
    surface, so it lights nothing and a good sampler never picks it from the floor. Their
    materials are 16 black Lambertian emitters, 4 colours (warm, cool, red, green) x 4
    emissiveStrengths (1.5, 4, 10, 25); the strongest warm and the strongest cool are doubleSided.
    A grey floor (16 x 16 at y = 0) carries six diffuse boxes; the camera stands at eye height
    under the canopy's near edge. Positions come from random.Random(7).random(), whose sequence
    Python keeps fixed across versions.
    """
    g = Gltf()
    rng = random.Random(7)
    floor = g.lambertian("floor", (0.5, 0.5, 0.5))
    grey = g.lambertian("box", (0.7, 0.7, 0.68))
    g.node({"name": "floor", "mesh": g.mesh("floor", g.geometry(*rectangle()), floor),
            "matrix": column_major([[8, 0, 0, 0], [0, 0, 8, 0], [0, -8, 0, -2]])})
    cube_mesh = g.mesh("box", g.geometry(*cube()), grey)
    boxes = [(-4.0, -3.0, 0.6, 0.8, 0.25), (-1.5, -5.0, 0.5, 1.4, -0.4), (1.8, -2.0, 0.8, 0.5, 0.7),
             (4.5, -4.5, 0.4, 1.0, 0.1), (0.2, 0.5, 0.35, 0.35, -0.9), (-3.0, 1.5, 0.45, 0.6, 1.2)]
    for k, (x, z, half, height, angle) in enumerate(boxes):
        c, s_ = math.cos(angle), math.sin(angle)
        rows = [[half * c, 0, half * s_, x], [0, height, 0, height], [-half * s_, 0, half * c, z]]
        g.node({"name": "box %d" % k, "mesh": cube_mesh, "matrix": column_major(rows)})

    materials = []
    for ci, colour in enumerate(MANY_LIGHTS_COLOURS):
        for si, strength in enumerate(MANY_LIGHTS_STRENGTHS):
            m = g.lambertian("emitter colour %d strength %g" % (ci, strength), (0.0, 0.0, 0.0),
                             colour, strength)
            if ci < 2 and si == len(MANY_LIGHTS_STRENGTHS) - 1:
                g.doc["materials"][m]["doubleSided"] = True
            materials.append(m)
    groups = [([], []) for _ in materials]
    (nx, nz), ((x0, x1), (z0, z1)) = MANY_LIGHTS_GRID, MANY_LIGHTS_AREA
    for j in range(nz):
        for i in range(nx):
            x = x0 + (i + 0.2 + 0.6 * rng.random()) * (x1 - x0) / nx
            z = z0 + (j + 0.2 + 0.6 * rng.random()) * (z1 - z0) / nz
            y = 3.0 + 0.5 * math.sin(0.7 * x) * math.cos(0.9 * z) + 0.3 * (rng.random() - 0.5)
            side = 0.06 + 0.1 * rng.random()
            # Front-face normal: straight down tilted by up to 50 degrees, or up for one in ten.
            tilt, azimuth = math.radians(50.0) * math.sqrt(rng.random()), 2 * math.pi * rng.random()
            up = rng.random() < 0.1
            n = (math.sin(tilt) * math.cos(azimuth), -math.cos(tilt), math.sin(tilt) * math.sin(azimuth))
            if up:
                n = tuple(-c for c in n)
            # Tangents t, b with t x b = n: the corners at angles 0, 120, 240 degrees about n
            # come counter-clockwise seen from the side n points to.
            t = normalize(cross((0.0, 0.0, 1.0), n))
            b = cross(n, t)
            spin = 2 * math.pi * rng.random()
            r = side / math.sqrt(3.0)
            corners = []
            for k in range(3):
                a = spin + k * 2 * math.pi / 3
                corners.append(tuple(float("%.6g" % (c + r * (math.cos(a) * t[q] + math.sin(a) * b[q])))
                                     for q, c in enumerate((x, y, z))))
            front = cross(sub(corners[1], corners[0]), sub(corners[2], corners[0]))
            assert sum(front[q] * n[q] for q in range(3)) > 0
            positions, triangles = groups[int(rng.random() * len(materials))]
            triangles.append(tuple(len(positions) + k for k in range(3)))
            positions.extend(corners)
    for k, (m, (positions, triangles)) in enumerate(zip(materials, groups)):
        mesh = g.mesh("emitters %d" % k, g.geometry(positions, triangles), m)
        g.node({"name": "emitters %d" % k, "mesh": mesh})
    g.camera("camera", math.radians(55.0), (0.0, 1.7, 8.5), aspect_ratio=1.5, pitch=math.radians(6.0))
    return g


def leaf():
    """A leaf lit from behind: KHR_materials_diffuse_transmission. The leaf is a flat outline of
    24 points (a fan about its centre, counter-clockwise seen from +Z, in the XY plane, 1.8
    tall), double-sided, dark green (baseColor (0.15, 0.35, 0.05), roughness 0.6) with
    diffuseTransmissionFactor 0.7 and a yellow-green diffuseTransmissionColorFactor
    (0.5, 0.9, 0.2); a 0.8 x 0.8 light (strength 6) 1.5 behind it faces it and the camera, which
    looks at the leaf's front from 3.2 in front; a grey floor 1.2 below.
    """
    g = Gltf()
    grey = g.lambertian("floor", (0.5, 0.5, 0.5))
    light = g.lambertian("light", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 6.0)
    green = g.material("leaf", (0.15, 0.35, 0.05), metallic=0.0, roughness=0.6, extensions={
        "KHR_materials_diffuse_transmission": {
            "diffuseTransmissionFactor": 0.7, "diffuseTransmissionColorFactor": [0.5, 0.9, 0.2]}})
    g.doc["materials"][green]["doubleSided"] = True
    outline = []
    for k in range(24):
        t = 2.0 * math.pi * k / 24
        # Narrower towards the tip (+Y) than the stem.
        width = 0.55 * math.sin(t) * (1.0 - 0.35 * math.cos(t))
        outline.append((round(width, 6), round(0.9 * math.cos(t), 6), 0.0))
    positions = [(0.0, 0.0, 0.0)] + outline
    # The outline runs clockwise seen from +Z (x = sin t): fan it the other way round.
    triangles = [(0, 1 + (k + 1) % 24, 1 + k) for k in range(24)]
    check_winding(positions, triangles, lambda centroid: (0.0, 0.0, 1.0))
    g.node({"name": "leaf", "mesh": g.mesh("leaf", g.geometry(positions, triangles), green)})
    rect = g.geometry(*rectangle())
    g.node({"name": "light", "mesh": g.mesh("light", rect, light),
            "matrix": column_major([[0.4, 0, 0, 0], [0, 0.4, 0, 0], [0, 0, 1, -1.5]])})
    g.node({"name": "floor", "mesh": g.mesh("floor", rect, grey),
            "matrix": column_major([[4, 0, 0, 0], [0, 0, 4, -1.2], [0, -4, 0, 0]])})
    g.camera("camera", math.radians(45.0), (0.0, 0.0, 3.2))
    return g


# The prism: glass of KHR_materials_ior 1.5 with KHR_materials_dispersion 2.0 (Abbe number 10: a
# rutile-like spread, beyond common glass, which the extension allows for effect).
PRISM_IOR, PRISM_DISPERSION = 1.5, 2.0
PRISM_SIDE, PRISM_HEIGHT, PRISM_TURN = 1.2, 1.2, math.radians(18.6)
PRISM_CAMERA_Z, PRISM_SLIT_DISTANCE = 4.0, 8.0


def dispersive_ior(wavelength):
    """KHR_materials_dispersion's n(lambda) (src/spectrum.rs, dispersive_ior)."""
    return max(PRISM_IOR + (PRISM_IOR - 1.0) * PRISM_DISPERSION / 20.0
               * (523655.0 / wavelength ** 2 - 1.5168), 1.0)


def prism_section():
    """The prism's cross-section in the XZ plane: an equilateral triangle of side PRISM_SIDE
    about the origin, apex towards +X, then turned by PRISM_TURN about +Y (x' = x cos + z sin,
    z' = -x sin + z cos) so that a camera ray along -Z meets its first face at the angle of
    minimum deviation, asin(1.5 sin 30 deg) = 48.6 deg. Corners counter-clockwise seen from +Y
    is not needed: returned in angle order 0, 120, 240 deg before the turn."""
    r = PRISM_SIDE / math.sqrt(3.0)
    c, s_ = math.cos(PRISM_TURN), math.sin(PRISM_TURN)
    corners = []
    for k in range(3):
        a = 2.0 * math.pi * k / 3.0
        x, z = r * math.cos(a), r * math.sin(a)
        corners.append((x * c + z * s_, -x * s_ + z * c))
    return corners


def trace_section(origin, direction, wavelength):
    """A ray in the XZ plane through the prism's cross-section (Snell's law at each face, no
    reflection): the exit point and direction, or None where it misses or is totally reflected."""
    corners = prism_section()
    n = dispersive_ior(wavelength)
    inside = False
    p, d = origin, direction
    for _ in range(2):
        best = None
        for k in range(3):
            a, b = corners[k], corners[(k + 1) % 3]
            e = (b[0] - a[0], b[1] - a[1])
            denom = d[0] * e[1] - d[1] * e[0]
            if abs(denom) < 1e-12:
                continue
            t = ((a[0] - p[0]) * e[1] - (a[1] - p[1]) * e[0]) / denom
            u = ((a[0] - p[0]) * d[1] - (a[1] - p[1]) * d[0]) / denom
            if t > 1e-9 and 0.0 <= u <= 1.0 and (best is None or t < best[0]):
                # Outward normal of a counter-clockwise (in x, z) edge: (e_z, -e_x) or its
                # opposite; pick the one pointing away from the centroid (the origin).
                normal = (e[1], -e[0])
                mid = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
                if normal[0] * mid[0] + normal[1] * mid[1] < 0:
                    normal = (-normal[0], -normal[1])
                length = math.hypot(*normal)
                best = (t, (normal[0] / length, normal[1] / length))
        if best is None:
            return None
        t, normal = best
        p = (p[0] + t * d[0], p[1] + t * d[1])
        eta = 1.0 / n if not inside else n
        m = normal if not inside else (-normal[0], -normal[1])  # on the incident side
        cos_i = -(d[0] * m[0] + d[1] * m[1])
        sin2_t = eta * eta * (1.0 - cos_i * cos_i)
        if sin2_t >= 1.0:
            return None
        cos_t = math.sqrt(1.0 - sin2_t)
        d = (eta * d[0] + (eta * cos_i - cos_t) * m[0], eta * d[1] + (eta * cos_i - cos_t) * m[1])
        inside = not inside
    return p, d


def prism_slit():
    """The slit's centre (x, z) and the direction from it back towards the prism: on the exit
    ray of the camera's central ray at the Fraunhofer d line, PRISM_SLIT_DISTANCE beyond the
    prism."""
    p, d = trace_section((0.0, PRISM_CAMERA_Z), (0.0, -1.0), 587.6)
    return (p[0] + PRISM_SLIT_DISTANCE * d[0], p[1] + PRISM_SLIT_DISTANCE * d[1]), (-d[0], -d[1])


def prism_apparent_angle(wavelength):
    """The angle (radians, positive towards +X) of the camera ray that, refracted at
    `wavelength`, meets the slit's centre: where the camera sees the slit in that colour."""
    (sx, sz), back = prism_slit()

    def miss(angle):
        d = (math.sin(angle), -math.cos(angle))
        out = trace_section((0.0, PRISM_CAMERA_Z), d, wavelength)
        p, e = out
        # Signed distance of the slit's centre from the exit ray.
        return (sx - p[0]) * e[1] - (sz - p[1]) * e[0]
    lo, hi = math.radians(-1.5), math.radians(6.0)
    f_lo = miss(lo)
    for _ in range(60):
        mid = (lo + hi) / 2
        if (miss(mid) > 0) == (f_lo > 0):
            lo, f_lo = mid, miss(mid)
        else:
            hi = mid
    return (lo + hi) / 2


def prism():
    """A glass prism splitting a white slit into its spectrum: KHR_materials_dispersion. The
    prism (see prism_section; 1.2 tall, standing on the floor at y = -0.6) is smooth glass
    (KHR_materials_transmission 1, ior 1.5, KHR_materials_volume thicknessFactor 1, dispersion
    2.0: Abbe number 10). The camera at (0, 0, 4) looks down -Z through it; its
    central ray leaves the prism deviated about 37 deg towards -X and meets, 8 further on, a
    white slit (0.12 wide, 1.2 tall, strength 12) facing back along it; the slit is outside the
    camera's view (25 deg to the left, the view's half-width is 22), so the camera sees it only through the prism, spread into a spectrum. Blue
    refracts more than red (n(450 nm) > n(650 nm)), so the camera must look further towards +X
    to see the slit in blue: the spectrum runs red to blue from left to right across the image
    (prism_apparent_angle gives 450, 550 and 650 nm at +3.3, +0.6 and -0.8 deg). A grey
    floor 0.01 below the prism, lit by the slit directly and through the prism; nothing else
    lights the scene.
    """
    g = Gltf()
    grey = g.lambertian("floor", (0.5, 0.5, 0.5))
    slit = g.lambertian("slit", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 12.0)
    glass = g.material("dispersive glass", (1.0, 1.0, 1.0), metallic=0.0, roughness=0.0, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0},
        "KHR_materials_ior": {"ior": PRISM_IOR},
        "KHR_materials_volume": {"thicknessFactor": 1.0},
        "KHR_materials_dispersion": {"dispersion": PRISM_DISPERSION}})
    corners = [(round(x, 6), round(z, 6)) for x, z in prism_section()]
    half = PRISM_HEIGHT / 2
    positions = [(x, -half, z) for x, z in corners] + [(x, half, z) for x, z in corners]
    triangles = [(0, 1, 2), (3, 5, 4)]
    for k in range(3):
        j = (k + 1) % 3
        triangles += [(k, 3 + k, 3 + j), (k, 3 + j, j)]
    def outward(centroid):
        return (centroid[0], 0.0, centroid[2]) if abs(centroid[1]) < half - 1e-6 else (0.0, centroid[1], 0.0)
    triangles = [t if sum(cross(sub(positions[t[1]], positions[t[0]]), sub(positions[t[2]], positions[t[0]]))[q]
                          * outward([sum(positions[i][q] for i in t) / 3 for q in range(3)])[q]
                          for q in range(3)) > 0 else (t[0], t[2], t[1]) for t in triangles]
    check_winding(positions, triangles, outward)
    g.node({"name": "prism", "mesh": g.mesh("prism", g.geometry(positions, triangles), glass)})
    (sx, sz), (bx, bz) = prism_slit()
    # The slit: the unit rectangle (normal +Z) scaled to 0.06 x 0.6 half-sizes and turned to
    # face (bx, 0, bz): local X -> (bz, 0, -bx), Y -> Y, Z -> (bx, 0, bz), a rotation (X x Y = Z).
    w, h = 0.06, 0.6
    rows = [[bz * w, 0, bx, round(sx, 6)], [0, h, 0, 0.0], [-bx * w, 0, bz, round(sz, 6)]]
    rows = [[round(v, 6) for v in row] for row in rows]
    g.node({"name": "slit", "mesh": g.mesh("slit", g.geometry(*rectangle()), slit),
            "matrix": column_major(rows)})
    g.node({"name": "floor", "mesh": g.mesh("floor", g.geometry(*rectangle()), grey),
            "matrix": column_major([[8, 0, 0, -2], [0, 0, 8, -half - 0.01], [0, -8, 0, -2]])})
    g.camera("camera", math.radians(30.0), (0.0, 0.0, PRISM_CAMERA_Z), aspect_ratio=1.5)
    return g


SCENES = [("cornell-box.gltf", cornell_box), ("cornell-materials.gltf", cornell_materials),
          ("furnace.gltf", furnace), ("veach-mis.gltf", veach_mis), ("instances.gltf", instances),
          ("many-lights.gltf", many_lights), ("caustic.gltf", caustic), ("leaf.gltf", leaf),
          ("prism.gltf", prism)]


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes")
    os.makedirs(root, exist_ok=True)
    for name, build in SCENES:
        path = os.path.normpath(os.path.join(root, name))
        build().write(path)
        print("wrote", path)


if __name__ == "__main__":
    main()
