#!/usr/bin/env python3
"""Times Embree's BVH builds on a glTF scene's triangles, beside `wavetrace bench --bvh`: what
the BVH build target (issue: at most 60 ms per million triangles on the project's 2 cores) looks
like for the builder most renderers use.

    pip install mitsuba        # its wheel carries libembree3 and Embree's headers
    python3 tools/embree_build.py SCENE.gltf [--threads 2] [--builds 7]

The scene's triangles (every mesh primitive that is a triangle list, placed by its node's world
matrix; instances are copied) go into one Embree triangle geometry, and `rtcCommitScene` is
timed at each build quality Embree offers: low (a Morton-code build), medium (binned SAH, its
default and Mitsuba's) and high (binned SAH with spatial splits). Each line gives the first
build (fresh memory, as a render's one build pays) and the median and best of the rest, in ms,
and ms per million triangles. A small C++ program does the timing: it is compiled here (g++,
which the glslang build already needs) against the wheel's library. Embree's builds also make
its leaves' triangle records and its 4- or 8-wide nodes, so compare them with wavetrace's build
plus its 4-wide collapse (`bench --bvh`'s "wide ms").

Python 3 standard library, g++ and the mitsuba wheel.
"""

import argparse
import array
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mitsuba_bench import load_gltf, mat_mul, node_matrix, read_accessor  # noqa: E402

DRIVER = r"""
#include <embree3/rtcore.h>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>
RTC_NAMESPACE_USE
int main(int argc, char** argv) {
    FILE* f = std::fopen(argv[1], "rb");
    long nv = 0, nt = 0;
    if (!f || std::fread(&nv, 8, 1, f) != 1 || std::fread(&nt, 8, 1, f) != 1) return 2;
    std::vector<float> v(3 * nv);
    std::vector<unsigned> t(3 * nt);
    if (std::fread(v.data(), 4, v.size(), f) != v.size() ||
        std::fread(t.data(), 4, t.size(), f) != t.size()) return 2;
    std::fclose(f);
    RTCDevice device = rtcNewDevice(argv[2]);
    int builds = std::atoi(argv[3]);
    const char* names[] = {"low (Morton)", "medium (binned SAH)", "high (spatial splits)"};
    for (int quality = 0; quality < 3; quality++) {
        std::vector<double> ms;
        for (int b = 0; b <= builds; b++) {
            RTCScene scene = rtcNewScene(device);
            rtcSetSceneBuildQuality(scene, (RTCBuildQuality)quality);
            RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
            rtcSetGeometryBuildQuality(g, (RTCBuildQuality)quality);
            std::memcpy(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                12, nv), v.data(), 12 * nv);
            std::memcpy(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                12, nt), t.data(), 12 * nt);
            rtcCommitGeometry(g);
            rtcAttachGeometry(scene, g);
            rtcReleaseGeometry(g);
            auto start = std::chrono::steady_clock::now();
            rtcCommitScene(scene);
            ms.push_back(std::chrono::duration<double, std::milli>(
                std::chrono::steady_clock::now() - start).count());
            rtcReleaseScene(scene);
        }
        double first = ms[0];
        std::sort(ms.begin() + 1, ms.end());
        double median = ms[1 + (ms.size() - 1) / 2];
        std::printf("%-22s %10ld %9.1f %8.1f %9.1f %10.1f\n", names[quality], nt, median,
                    ms[1], first, median * 1e6 / (nt > 0 ? nt : 1));
    }
    rtcReleaseDevice(device);
    return 0;
}
"""


def triangles(path):
    """World-space vertices (flat floats) and triangle indices of the scene's triangle lists."""
    doc, buffers = load_gltf(path)
    vertices, indices = array.array("f"), array.array("I")
    identity = [[float(r == c) for c in range(4)] for r in range(4)]

    def visit(index, parent):
        node = doc["nodes"][index]
        world = mat_mul(parent, node_matrix(node))
        if "mesh" in node:
            for prim in doc["meshes"][node["mesh"]]["primitives"]:
                if prim.get("mode", 4) != 4:
                    continue
                base = len(vertices) // 3
                for p in read_accessor(path, doc, buffers, prim["attributes"]["POSITION"]):
                    vertices.extend(
                        sum(world[r][c] * q for c, q in enumerate((*p, 1.0))) for r in range(3)
                    )
                count = len(vertices) // 3 - base
                if "indices" in prim:
                    flat = [i[0] for i in read_accessor(path, doc, buffers, prim["indices"])]
                else:
                    flat = list(range(count))
                indices.extend(base + i for i in flat[: len(flat) - len(flat) % 3])
        for child in node.get("children", []):
            visit(child, world)

    scene = doc.get("scene", 0)
    roots = doc["scenes"][scene]["nodes"] if doc.get("scenes") else range(len(doc.get("nodes", [])))
    for root in roots:
        visit(root, identity)
    return vertices, indices


def main():
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--builds", type=int, default=7, help="timed builds after the first")
    args = ap.parse_args()
    try:
        import mitsuba
    except ImportError:
        sys.exit("embree_build: the mitsuba wheel is not installed (pip install mitsuba)")
    wheel = os.path.dirname(mitsuba.__file__)
    with tempfile.TemporaryDirectory() as folder:
        source, binary = os.path.join(folder, "driver.cpp"), os.path.join(folder, "driver")
        with open(source, "w") as f:
            f.write(DRIVER)
        subprocess.run(
            ["g++", "-O2", "-std=c++17", "-I", os.path.join(wheel, "include"),
             source, "-o", binary, "-L", wheel, "-lembree3", f"-Wl,-rpath,{wheel}"],
            check=True,
        )
        print(f"Embree ({wheel}), {args.threads} threads, {args.builds} builds after the first")
        print(f"{'scene / quality':<22} {'triangles':>10} {'build ms':>9} {'best ms':>8} "
              f"{'first ms':>9} {'ms per M':>10}")
        for path in args.scenes:
            vertices, indices = triangles(path)
            data = os.path.join(folder, "triangles.bin")
            with open(data, "wb") as f:
                array.array("q", [len(vertices) // 3, len(indices) // 3]).tofile(f)
                vertices.tofile(f)
                indices.tofile(f)
            print(os.path.basename(path))
            subprocess.run(
                [binary, data, f"threads={args.threads}", str(args.builds)], check=True
            )


if __name__ == "__main__":
    main()
