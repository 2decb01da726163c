#!/usr/bin/env python3
"""Copies glTF seeds into the fuzzer's corpus folder (seed.sh runs it). Python 3 stdlib only.

    python3 tools/fuzz/embed.py --out DIR [--max-len BYTES] SOURCE_DIR...

Every .gltf and .glb under each SOURCE_DIR is copied as it is (the fuzz target reads one byte
string, so a relative URI resolves to nothing there); a .gltf whose buffers or images name
regular files beside it is also written with those files inlined as base64 `data:` URIs, so the
fuzzer starts from the whole model (an image over an eighth of --max-len is replaced by a 2×2
PNG). Files over --max-len bytes (libFuzzer's -max_len) are left
out: libFuzzer would truncate them. Names are the source path with '/' as '__'.
"""

import argparse
import base64
import json
import os
import sys
import struct
import urllib.parse
import zlib

# Stands in for an image file too large to inline: 2×2 RGBA, mid grey.
def tiny_png():
    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))
    rows = b"".join(b"\x00" + b"\x80\x80\x80\xff" * 2 for _ in range(2))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 2, 2, 8, 6, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def mime(data):
    if data.startswith(b"\x89PNG\r\n\x1a\n"):
        return "image/png"
    if data.startswith(b"\xff\xd8\xff"):
        return "image/jpeg"
    return "application/octet-stream"


def inline(path, text, max_len):
    """The glTF JSON of `path` with its relative file URIs inlined, or None if none were."""
    try:
        doc = json.loads(text)
    except (ValueError, RecursionError):
        return None
    if not isinstance(doc, dict):
        return None
    folder = os.path.dirname(path)
    changed = False
    for key in ("buffers", "images"):
        items = doc.get(key)
        if not isinstance(items, list):
            continue
        for item in items:
            uri = item.get("uri") if isinstance(item, dict) else None
            if not isinstance(uri, str) or uri.startswith("data:") or ":" in uri:
                continue
            rel = urllib.parse.unquote(uri)
            if os.path.isabs(rel) or ".." in rel.split("/"):
                continue
            target = os.path.join(folder, rel)
            if os.path.islink(target) or not os.path.isfile(target):
                continue
            if os.path.getsize(target) <= max_len // (8 if key == "images" else 2):
                with open(target, "rb") as f:
                    data = f.read()
            elif key == "images":
                data = tiny_png()
            else:
                return None
            item["uri"] = "data:%s;base64,%s" % (mime(data), base64.b64encode(data).decode())
            changed = True
    return json.dumps(doc, separators=(",", ":")).encode() if changed else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--max-len", type=int, default=512 * 1024)
    ap.add_argument("sources", nargs="+")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    written = skipped = 0
    for source in args.sources:
        if not os.path.isdir(source):
            print("seed: %s is absent, skipped" % source, file=sys.stderr)
            continue
        parent = os.path.dirname(os.path.abspath(source))
        for dirpath, _, files in sorted(os.walk(source)):
            for name in sorted(files):
                if not name.endswith((".gltf", ".glb")):
                    continue
                path = os.path.join(dirpath, name)
                if os.path.islink(path) or not os.path.isfile(path):
                    continue
                stem = os.path.relpath(path, parent).replace(os.sep, "__")
                with open(path, "rb") as f:
                    data = f.read()
                outputs = [(stem, data)]
                if name.endswith(".gltf"):
                    embedded = inline(path, data, args.max_len)
                    if embedded is not None:
                        outputs.append((stem[: -len(".gltf")] + "-embedded.gltf", embedded))
                for out_name, out_data in outputs:
                    if len(out_data) > args.max_len:
                        skipped += 1
                        continue
                    with open(os.path.join(args.out, out_name), "wb") as f:
                        f.write(out_data)
                    written += 1
    print("seed: %d files in %s (%d over %d bytes left out)"
          % (written, args.out, skipped, args.max_len), file=sys.stderr)


if __name__ == "__main__":
    main()
