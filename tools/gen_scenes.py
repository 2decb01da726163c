#!/usr/bin/env python3
"""Writes the committed test scenes as self-contained glTF 2.0 files (base64 data: buffers).

    python3 tools/gen_scenes.py           # writes scenes/cornell-box.gltf and scenes/furnace.gltf
    python3 tools/gen_scenes.py OUT_DIR   # writes them into OUT_DIR instead

Output is deterministic (same bytes on every run). Python 3 standard library only.

- cornell-box.gltf: the Cornell box of Mitsuba/pbrt test scenes, built from unit primitives
  (rectangle [-1,1]^2 in local XY with normal +Z; cube [-1,1]^3 with outward normals) placed by
  node matrices. Reflectances are Lambertian (baseColorFactor); the light emits radiance
  (18.387, 13.9873, 6.75357) from its front face, encoded as emissiveFactor = radiance / max
  component and KHR_materials_emissive_strength = max component.
- furnace.gltf: a closed unit icosphere (subdivision 3, watertight) facing inwards with albedo
  0.5 and emission 0.5, camera at the centre: the exact radiance everywhere is
  Le / (1 - a) = 1.
"""

import base64
import json
import math
import os
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
    """Unit icosphere with shared vertices, every triangle counter-clockwise seen from inside."""
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
    inward = [(a, c, b) for a, b, c in faces]
    check_winding(positions, inward, lambda centroid: tuple(-x for x in centroid))
    return positions, inward


def normalize(p):
    length = math.sqrt(sum(x * x for x in p))
    return tuple(x / length for x in p)


def check_winding(positions, triangles, outward_of):
    """Asserts that every geometric normal points along outward_of(centroid)."""
    for tri in triangles:
        p0, p1, p2 = (positions[i] for i in tri)
        e1 = [p1[k] - p0[k] for k in range(3)]
        e2 = [p2[k] - p0[k] for k in range(3)]
        n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
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
        self.doc["bufferViews"].append(
            {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data), "target": target})
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

    def material(self, name, base_color, emissive=None, strength=None):
        material = {
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": list(base_color) + [1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "doubleSided": False,
        }
        if emissive is not None:
            material["emissiveFactor"] = list(emissive)
        if strength is not None:
            material["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}
            self.doc["extensionsUsed"] = ["KHR_materials_emissive_strength"]
        self.doc["materials"].append(material)
        return len(self.doc["materials"]) - 1

    def mesh(self, name, geometry, material):
        self.doc["meshes"].append({"name": name, "primitives": [dict(geometry, material=material)]})
        return len(self.doc["meshes"]) - 1

    def node(self, node):
        self.doc["nodes"].append(node)
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def camera(self, name, yfov, translation):
        self.doc["cameras"].append({"name": name, "type": "perspective", "perspective": {
            "yfov": yfov, "aspectRatio": 1.0, "znear": 0.01}})
        node = {"name": name, "camera": len(self.doc["cameras"]) - 1}
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

def cornell_box():
    g = Gltf()
    white = g.material("white", (0.885809, 0.698859, 0.666422))
    red = g.material("red", (0.570068, 0.0430135, 0.0443706))
    green = g.material("green", (0.105421, 0.37798, 0.076425))
    radiance = (18.387, 13.9873, 6.75357)
    peak = max(radiance)
    light = g.material("light", (0.885809, 0.698859, 0.666422), [c / peak for c in radiance], peak)

    rect, box = g.geometry(*rectangle()), g.geometry(*cube())
    meshes = {
        "white rectangle": g.mesh("white rectangle", rect, white),
        "red rectangle": g.mesh("red rectangle", rect, red),
        "green rectangle": g.mesh("green rectangle", rect, green),
        "light rectangle": g.mesh("light rectangle", rect, light),
        "white cube": g.mesh("white cube", box, white),
    }
    shapes = [
        ("floor", "white rectangle", [[1, 0, 0, 0], [0, 0, 1, -1], [0, -1, 0, 0]]),
        ("ceiling", "white rectangle", [[1, 0, 0, 0], [0, 0, -1, 1], [0, 1, 0, 0]]),
        ("back wall", "white rectangle", [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -1]]),
        ("green wall", "green rectangle", [[0, 0, -1, 1], [0, 1, 0, 0], [1, 0, 0, 0]]),
        ("red wall", "red rectangle", [[0, 0, 1, -1], [0, 1, 0, 0], [-1, 0, 0, 0]]),
        ("light", "light rectangle", [[0.23, 0, 0, 0], [0, 0, -0.19, 0.99], [0, 0.19, 0, 0.01]]),
        ("tall box", "white cube",
         [[0.28491, 0, 0.0939491, -0.33], [0, 0.61, 0, -0.4], [-0.0939491, 0, 0.28491, -0.28]]),
        ("short box", "white cube",
         [[0.286891, 0, -0.0877115, 0.335], [0, 0.3, 0, -0.7], [0.0877115, 0, 0.286891, 0.38]]),
    ]
    for name, mesh, rows in shapes:
        g.node({"name": name, "mesh": meshes[mesh], "matrix": column_major(rows)})
    g.camera("camera", math.radians(39.3077), (0.0, 0.0, 3.9))
    return g


def furnace():
    g = Gltf()
    material = g.material("furnace", (0.5, 0.5, 0.5), (0.5, 0.5, 0.5))
    sphere = g.mesh("sphere", g.geometry(*icosphere(3)), material)
    g.node({"name": "sphere", "mesh": sphere})
    g.camera("camera", math.radians(60.0), None)
    return g


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes")
    os.makedirs(root, exist_ok=True)
    for name, scene in (("cornell-box.gltf", cornell_box()), ("furnace.gltf", furnace())):
        path = os.path.normpath(os.path.join(root, name))
        scene.write(path)
        print("wrote", path)


if __name__ == "__main__":
    main()
