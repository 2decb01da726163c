#!/usr/bin/env python3
"""Structure-aware mutational fuzzer of wavetrace's glTF loader (issue 7). Python 3 stdlib only.

    python3 tools/fuzz_gltf.py --minutes 30 [--binary target/release/wavetrace]
                               [--seeds DIR ...] [--out fuzz-out]

Seeds: every .gltf/.glb under ../shared/gltf-samples/valid and tests/hostile (each seed's folder
is copied into a work folder so that its relative URIs resolve). Each execution mutates one seed
at the JSON level (delete, duplicate or replace members; huge, negative, fractional and 2^32+
indices; wrong types; hostile URIs; camera types; counts and byte lengths scaled up) or at the
byte level (truncated or corrupted GLB headers and chunks, flipped bytes), then renders it 1x1 at
1 spp on the CPU under --max-memory, a timeout and an address-space limit, and records:

- findings: a signal, an exit status other than 0 or 1, a caught panic ("panicked" in stderr),
  a timeout (hang), or a peak resident size above the budget plus the program's footprint; each
  is saved with its input under OUT/findings/;
- for clean errors, whether the message names a JSON path (or a GLB chunk and byte offset).

Not run by CI (CI runs the corpus in tests/hostile.rs); run it by hand, e.g. at `nice -n 19`.
"""

import argparse
import copy
import json
import os
import random
import re
import resource
import shutil
import struct
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MAX_MEMORY = 512 << 20
FOOTPRINT = 128 << 20
ADDRESS_SPACE = 8 << 30
TIMEOUT_S = 20

EDGE_NUMBERS = [0, 1, 2, 3, -1, -2**31, 2**31 - 1, 2**31, 2**32 - 1, 2**32, 2**32 + 1,
                2**53, 2**63, 2**64, 2**64 + 5, 1e308, -1e308, 0.5, -0.0, 1e-310, 65535, 65536,
                4294967295 * 12, 10**30]
HOSTILE_STRINGS = ["", "x", "../secret.bin", "../../../../etc/passwd", "/etc/passwd", "/dev/zero",
                   "/dev/urandom", "/proc/self/mem", "file:///etc/passwd", "%2e%2e/%2e%2e/etc/passwd",
                   "data:application/octet-stream;base64,AAAA", "data:,", "data:;base64,****",
                   "http://localhost/x.bin", ".", "sub/../../x", "\u0000", "a" * 5000,
                   "perspective", "orthographic", "POSITION", "KHR_draco_mesh_compression",
                   "KHR_materials_emissive_strength"]
# A message names a location if it holds a JSON path (`meshes[0]`, `cameras[2].perspective`,
# `asset.version`, a top-level member), "the top level", or a GLB chunk / header byte offset.
TOP_LEVEL = ("asset", "scene", "scenes", "nodes", "meshes", "accessors", "bufferViews",
             "buffers", "materials", "cameras", "images", "textures", "samplers", "skins",
             "animations", "extensionsUsed", "extensionsRequired", "extensions", "extras")
PATH_RE = re.compile(r"(^|\b[A-Za-z_]\w*)\[\d+\]|the top level|GLB (header|chunk)|\b(%s)\b(:|\.)"
                     r"|^[^\s:\[\]]+(\[\d+\]|\.[^\s:]+)*: invalid JSON" % "|".join(TOP_LEVEL))


def split_glb(data):
    """(json document, bin bytes or None), or None if the GLB does not parse."""
    try:
        length, kind = struct.unpack_from("<II", data, 12)
        text = data[20:20 + length]
        rest = data[20 + length + (-length % 4):]
        bin_chunk = None
        if len(rest) >= 8:
            blen, bkind = struct.unpack_from("<II", rest, 0)
            if bkind == 0x004E4942:
                bin_chunk = rest[8:8 + blen]
        return json.loads(text), bin_chunk
    except Exception:
        return None


def join_glb(doc, bin_chunk):
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    chunks = struct.pack("<II", len(text), 0x4E4F534A) + text
    if bin_chunk is not None:
        bin_chunk += b"\0" * (-len(bin_chunk) % 4)
        chunks += struct.pack("<II", len(bin_chunk), 0x004E4942) + bin_chunk
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


def containers(value, path=()):
    """Every (path, object or array) inside a JSON value."""
    if isinstance(value, (dict, list)):
        yield path, value
        items = value.items() if isinstance(value, dict) else enumerate(value)
        for k, v in items:
            yield from containers(v, path + (k,))


def leaves(value, path=()):
    items = value.items() if isinstance(value, dict) else enumerate(value) \
        if isinstance(value, list) else None
    if items is None:
        yield path, value
        return
    for k, v in items:
        yield from leaves(v, path + (k,))


def set_at(doc, path, value):
    for k in path[:-1]:
        doc = doc[k]
    doc[path[-1]] = value


def random_value(rng):
    r = rng.random()
    if r < 0.45:
        return rng.choice(EDGE_NUMBERS)
    if r < 0.7:
        return rng.choice(HOSTILE_STRINGS)
    return rng.choice([None, True, False, [], {}, [0] * rng.choice([1, 5, 17]), {"x": 1},
                       [[[[]]]], [2**32] * 3])


def mutate_json(doc, rng):
    """One structure-aware change to a JSON document, in place."""
    spots = list(containers(doc))
    path, box = rng.choice(spots)
    op = rng.randrange(11)
    keys = list(box.keys()) if isinstance(box, dict) else list(range(len(box)))
    if op == 0 and keys:  # delete a member or element
        del box[rng.choice(keys)]
    elif op == 1 and keys:  # duplicate a member's value or an element
        k = rng.choice(keys)
        if isinstance(box, list):
            box.insert(rng.randrange(len(box) + 1), copy.deepcopy(box[k]))
        else:
            box[rng.choice(keys)] = copy.deepcopy(box[k])
    elif op in (2, 3, 4):  # replace a leaf (indices, counts, lengths are the leaves)
        lv = [(p, v) for p, v in leaves(doc) if p]
        if lv:
            p, v = rng.choice(lv)
            if isinstance(v, int) and not isinstance(v, bool) and rng.random() < 0.5:
                v = rng.choice([v + 1, v - 1, v * 2, v * 1000, v + 2**32, -v, v * 2**20])
            else:
                v = random_value(rng)
            set_at(doc, p, v)
    elif op == 5 and keys:  # wrong type for a container member
        set_at(doc, path + (rng.choice(keys),), random_value(rng))
    elif op == 6:  # hostile URI
        targets = [p for p, v in leaves(doc) if p and p[-1] == "uri"]
        if targets:
            set_at(doc, rng.choice(targets), rng.choice(HOSTILE_STRINGS[:16]))
        elif doc.get("buffers"):
            doc["buffers"][0]["uri"] = rng.choice(HOSTILE_STRINGS[:16])
    elif op == 7:  # cameras
        cams = doc.setdefault("cameras", [])
        cams.append({"type": rng.choice(["perspective", "orthographic", "fisheye", 3]),
                     rng.choice(["perspective", "orthographic"]):
                         rng.choice([{"yfov": 1, "znear": 0.1}, {}, None, 5])})
        if doc.get("nodes"):
            rng.choice(doc["nodes"])["camera"] = rng.choice([len(cams) - 1, len(cams), 2**32])
    elif op == 8:  # scale counts and byte lengths
        lv = [(p, v) for p, v in leaves(doc)
              if p and p[-1] in ("count", "byteLength", "byteOffset", "byteStride")]
        if lv:
            p, v = rng.choice(lv)
            set_at(doc, p, (v if isinstance(v, int) else 1) * rng.choice([2, 1000, 2**20, 2**30]))
    elif op == 9:  # instancing: many nodes on one mesh
        if doc.get("meshes") and doc.get("scenes"):
            n = rng.choice([100, 1000, 20000])
            base = len(doc.setdefault("nodes", []))
            doc["nodes"].extend({"mesh": 0} for _ in range(n))
            doc["scenes"][0]["nodes"] = list(range(base, base + n))
    elif op == 10 and isinstance(box, list):  # lengthen or shorten an array
        if box and rng.random() < 0.5:
            del box[rng.randrange(len(box)):]
        else:
            box.extend([copy.deepcopy(box[0]) if box else 0] * rng.choice([1, 3]))


def mutate_bytes(data, rng):
    data = bytearray(data)
    op = rng.randrange(5)
    if op == 0 and data:
        del data[rng.randrange(len(data)):]
    elif op == 1 and data:
        for _ in range(rng.choice([1, 4, 32])):
            data[rng.randrange(len(data))] = rng.randrange(256)
    elif op == 2 and len(data) >= 24:  # a header or chunk length
        off = rng.choice([4, 8, 12, 16])
        data[off:off + 4] = struct.pack("<I", rng.choice([0, 1, 7, 2**31, 2**32 - 1,
                                                          len(data), len(data) + 8]))
    elif op == 3 and data:
        pos = rng.randrange(len(data))
        data[pos:pos] = bytes(rng.choice([b"[", b"{", b"\0", b"\xff", b'"', b"]]]]"]) * rng.choice([1, 200]))
    elif op == 4:
        data += bytes(rng.randrange(256) for _ in range(rng.choice([1, 9, 100])))
    return bytes(data)


def mutant(seed_bytes, is_glb, rng):
    """Mutated file bytes of a seed."""
    if rng.random() < 0.15:
        return mutate_bytes(seed_bytes, rng)
    if is_glb:
        parsed = split_glb(seed_bytes)
        if parsed is None:
            return mutate_bytes(seed_bytes, rng)
        doc, bin_chunk = parsed
    else:
        try:
            doc, bin_chunk = json.loads(seed_bytes), None
        except Exception:
            return mutate_bytes(seed_bytes, rng)
    if not isinstance(doc, dict):
        return mutate_bytes(seed_bytes, rng)
    for _ in range(rng.choice([1, 1, 2, 3])):
        try:
            mutate_json(doc, rng)
        except (TypeError, KeyError, IndexError, AttributeError, ValueError):
            pass  # an earlier mutation changed the shape this one expected
    if is_glb:
        if bin_chunk is not None and rng.random() < 0.2:
            bin_chunk = mutate_bytes(bin_chunk, rng)
        data = join_glb(doc, bin_chunk)
    else:
        data = json.dumps(doc).encode()
    return mutate_bytes(data, rng) if rng.random() < 0.05 else data


def limit_child():
    os.nice(19)
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def run(binary, scene, out_png):
    """(exit code or -signal or None on timeout, stderr, peak RSS bytes, seconds)."""
    start = time.monotonic()
    with tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(
            [binary, "render", "--device", "cpu", "--spp", "1", "--width", "1", "--height", "1",
             "--max-depth", "1", "--max-memory", str(MAX_MEMORY), "-o", out_png, scene],
            stdout=subprocess.DEVNULL, stderr=err, preexec_fn=limit_child)
        code, peak = None, 0
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                code = os.waitstatus_to_exitcode(status)
                peak = usage.ru_maxrss * 1024
                proc.returncode = code
                break
            if time.monotonic() - start > TIMEOUT_S:
                proc.kill()
                os.wait4(proc.pid, 0)
                proc.returncode = -9
                break
            time.sleep(0.002)
        err.seek(0)
        text = err.read().decode("utf-8", "replace")
    return code, text, peak, time.monotonic() - start


def collect_seeds(dirs):
    seeds = []
    for d in dirs:
        for base, _, files in os.walk(d):
            seeds += [os.path.join(base, f) for f in sorted(files) if f.endswith((".gltf", ".glb"))]
    return seeds


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, default=30)
    ap.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "wavetrace"))
    ap.add_argument("--seeds", nargs="*", default=[
        os.path.join(ROOT, "..", "shared", "gltf-samples", "valid"), os.path.join(ROOT, "tests", "hostile")])
    ap.add_argument("--out", default="fuzz-out")
    ap.add_argument("--rng", type=int, default=1)
    args = ap.parse_args()
    rng = random.Random(args.rng)
    work = tempfile.mkdtemp(prefix="wavetrace-fuzz-")
    findings_dir = os.path.join(args.out, "findings")
    os.makedirs(findings_dir, exist_ok=True)
    # Each seed's folder is copied once so that mutants beside it resolve its relative URIs.
    seeds = []
    for i, path in enumerate(collect_seeds([s for s in args.seeds if os.path.isdir(s)])):
        folder = os.path.join(work, f"s{i}")
        shutil.copytree(os.path.dirname(path), folder, symlinks=True,
                        ignore=lambda d, names: [n for n in names if n.endswith((".gltf", ".glb"))
                                                 and n != os.path.basename(path)])
        with open(path, "rb") as f:
            seeds.append((folder, f.read(), path.endswith(".glb"), path))
    print(f"{len(seeds)} seeds, binary {args.binary}, {args.minutes} minutes", flush=True)

    stats = {"executions": 0, "ok": 0, "errors": 0, "errors_with_path": 0}
    findings, unlocated, exit_codes = {}, {}, {}
    deadline = time.monotonic() + 60 * args.minutes
    out_png = os.path.join(work, "out.png")
    while time.monotonic() < deadline:
        # Mostly the valid samples, as in the fuzz; the hostile corpus for the rest.
        valid = [s for s in seeds if "hostile" not in s[3]] or seeds
        folder, seed, is_glb, origin = rng.choice(valid if rng.random() < 0.8 else seeds)
        data = mutant(seed, is_glb, rng)
        scene = os.path.join(folder, "mutant.glb" if is_glb else "mutant.gltf")
        with open(scene, "wb") as f:
            f.write(data)
        code, err, peak, seconds = run(args.binary, scene, out_png)
        stats["executions"] += 1
        exit_codes[str(code)] = exit_codes.get(str(code), 0) + 1
        kind = None
        if code is None:
            kind = "timeout"
        elif code < 0:
            kind = f"signal {-code}"
        elif code not in (0, 1):
            kind = f"exit {code}"
        elif "panicked" in err:
            kind = "caught panic"
        elif peak > MAX_MEMORY + FOOTPRINT:
            kind = f"peak {peak >> 20} MiB"
        if code == 0:
            stats["ok"] += 1
        elif code == 1:
            stats["errors"] += 1
            message = err.strip().splitlines()[-1] if err.strip() else ""
            message = re.sub(r"^error: cannot load scene \S+: ", "", message)
            if PATH_RE.search(message):
                stats["errors_with_path"] += 1
            else:
                sig = re.sub(r"\d+", "N", message)[:100]
                unlocated[sig] = unlocated.get(sig, 0) + 1
        if kind:
            sig = kind + ": " + re.sub(r"\d+", "N", (err.strip().splitlines() or [""])[-1])[:120]
            if sig not in findings:
                name = f"f{len(findings)}" + (".glb" if is_glb else ".gltf")
                with open(os.path.join(findings_dir, name), "wb") as f:
                    f.write(data)
                findings[sig] = {"count": 0, "file": name, "seed": origin, "stderr": err[-2000:]}
                print(f"FINDING {sig} ({name}, seed {origin})", flush=True)
            findings[sig]["count"] += 1
        if stats["executions"] % 500 == 0:
            print(json.dumps(stats), flush=True)
    shutil.rmtree(work, ignore_errors=True)
    share = stats["errors_with_path"] / max(1, stats["errors"])
    report = {"stats": stats, "share_of_errors_naming_a_path": share, "exit_codes": exit_codes,
              "findings": findings,
              "unlocated_messages": dict(sorted(unlocated.items(), key=lambda x: -x[1])[:40])}
    with open(os.path.join(args.out, "report.json"), "w") as f:
        json.dump(report, f, indent=1)
    print(json.dumps({k: report[k] for k in ("stats", "share_of_errors_naming_a_path", "exit_codes")}))
    print(f"{len(findings)} distinct findings; report in {args.out}/report.json")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
