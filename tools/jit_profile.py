#!/usr/bin/env python3
"""Where lavapipe's kernels spend their instructions, instruction by instruction: the wavefront
kernels llvmpipe compiles at run time, profiled under callgrind and disassembled.

`tools/instructions.py --device gpu` counts the kernels' instructions per sample; this tool says
which of them. callgrind records every executed instruction's address, including those of the
code llvmpipe generates (`--smc-check=all`), but it cannot name or show that code, which lives in
anonymous memory and is gone when the program ends. So the render runs under callgrind with its
gdb server (`--vgdb=yes`), and gdb stops it where wavetrace destroys its pipelines
(`Pipelines::drop`, src/gpu/pipelines.rs), asks callgrind for its counts so far (`monitor
dump`), and copies out the code of the functions without an object file that ran the most
instructions: the kernels and the image-load function they call. objdump disassembles each, and
every instruction is listed with how many times it ran.

    tools/jit_profile.py target/release/wavetrace [--scene scenes/cornell-box.gltf]
        [--size 32] [--spp 36] [--top 6] [--out DIR] [-- RENDER OPTIONS]

It prints, per function: its instructions in all and per sample, its length, and its most
executed stretches of code (the instructions that ran the same number of times, which are one
loop body or one straight run between branches): a loop body that runs more often than the work
it does (the trip in which every lane leaves a `while` loop, bvh.glsl) shows there. DIR keeps
each function's listing (`fn-ADDRESS.txt`: count, address, instruction). callgrind cannot name
the kernels: the largest, with the most calls, is `shade`; `extend` and `connect` each call the
image function four times in their node loop (the closest-hit walk's also sorts its slots:
`vcmpltps`/`vcmpeqps` pairs); the image function is the short one every kernel calls.

One llvmpipe thread (LP_NUM_THREADS=1), after an uncounted run under valgrind that fills Mesa's
shader cache (tools/instructions.py says why under valgrind). Needs valgrind, gdb (with its
Python) and objdump; the binary built with debug information (the release profile has it).
A Cornell box at 32², 36 spp takes about a minute.
"""

import argparse
import collections
import json
import os
import re
import subprocess
import sys
import tempfile
import time

from instructions import split_render_options

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def parse_callgrind(path):
    """Exclusive instructions per (object, function, address) of a callgrind file written with
    --dump-instr=yes (positions: instr line), its name and position compression undone."""
    names = {"ob": {}, "fn": {}, "fl": {}}
    cost = collections.defaultdict(int)
    ob = fn = None
    positions = ["line"]
    last = [0, 0]
    call_line = False

    def name(kind, rest):
        m = re.match(r"\((\d+)\)(?: (.*))?$", rest)
        if not m:
            return rest
        if m.group(2) is not None:
            names[kind][m.group(1)] = m.group(2)
        return names[kind].get(m.group(1), "?")

    with open(path, errors="replace") as f:
        for line in f:
            line = line.rstrip("\n")
            if not line:
                continue
            if line.startswith("positions:"):
                positions = line.split()[1:]
                last = [0] * len(positions)
                continue
            if line[0].isdigit() or line[0] in "+-*":
                parts = line.split()
                for k, p in enumerate(parts[: len(positions)]):
                    if p == "*":
                        continue
                    last[k] = last[k] + int(p, 0) if p[0] in "+-" else int(p, 0)
                if call_line:
                    # The line after calls= is the call's inclusive cost, not this function's.
                    call_line = False
                    continue
                if len(parts) > len(positions):
                    cost[(ob, fn, last[0])] += int(parts[len(positions)])
                continue
            key, _, rest = line.partition("=")
            if key == "ob":
                ob = name("ob", rest)
            elif key == "fn":
                fn = name("fn", rest)
            elif key == "cob":
                name("ob", rest)
            elif key == "cfn":
                name("fn", rest)
            elif key in ("fl", "fi", "fe", "cfi", "cfl"):
                name("fl", rest)
            elif key == "calls":
                call_line = True
    return cost


def jit_functions(cost, top):
    """The `top` functions without an object file (generated code) by instructions: (function,
    instructions, lowest and highest address executed)."""
    per = collections.defaultdict(lambda: [0, 1 << 64, 0])
    for (ob, fn, a), ir in cost.items():
        if ob not in (None, "???"):
            continue
        e = per[fn]
        e[0] += ir
        e[1] = min(e[1], a)
        e[2] = max(e[2], a)
    ranked = sorted(per.items(), key=lambda kv: -kv[1][0])[:top]
    return [(fn, ir, lo, hi) for fn, (ir, lo, hi) in ranked]


def gdb_dump(out, top):
    """Run inside gdb at the breakpoint: has callgrind dump its counts, then copies the code of
    the top generated functions to files beside them and lists them in jit.json."""
    import gdb  # noqa: F401 (gdb's own module, there only)

    gdb.execute("monitor dump")
    dumps = sorted(
        (p for p in os.listdir(out) if re.match(r"callgrind\.out\.\d+$", p)),
        key=lambda p: int(p.rsplit(".", 1)[1]),
    )
    path = os.path.join(out, dumps[-1])
    funcs = []
    for fn, ir, lo, hi in jit_functions(parse_callgrind(path), top):
        code = os.path.join(out, "code-%x.bin" % lo)
        # The last instruction executed is at most 15 bytes long.
        gdb.execute("dump binary memory %s 0x%x 0x%x" % (code, lo, hi + 16))
        funcs.append({"function": fn, "instructions": ir, "low": lo, "high": hi, "code": code})
    with open(os.path.join(out, "jit.json"), "w") as f:
        json.dump({"callgrind": path, "functions": funcs}, f)


def breakpoint_line():
    """The line of src/gpu/pipelines.rs where Pipelines::drop destroys its first pipeline."""
    with open(os.path.join(ROOT, "src", "gpu", "pipelines.rs")) as f:
        lines = f.read().split("\n")
    start = next(i for i, l in enumerate(lines) if l.startswith("impl Drop for Pipelines"))
    at = next(i for i in range(start, len(lines)) if "destroy_pipeline(" in lines[i])
    return at + 1


def listing(func, cost):
    """(count, address, instruction) per instruction of a dumped function."""
    dis = subprocess.run(
        ["objdump", "-D", "-b", "binary", "-mi386:x86-64", "--adjust-vma=%d" % func["low"],
         func["code"]],
        stdout=subprocess.PIPE, text=True, check=True,
    ).stdout
    rows = []
    for line in dis.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\s+(?:[0-9a-f]{2} )+\s*(.*)$", line)
        if m:
            a = int(m.group(1), 16)
            if a > func["high"]:
                break
            rows.append((cost.get(a, 0), a, m.group(2).strip()))
    return rows


def main():
    argv, render = split_render_options(sys.argv[1:])
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("binary", help="wavetrace binary (with debug information)")
    ap.add_argument("--scene", default=os.path.join(ROOT, "scenes", "cornell-box.gltf"))
    ap.add_argument("--size", type=int, default=32, help="image width and height")
    ap.add_argument("--spp", type=int, default=36)
    ap.add_argument("--top", type=int, default=6, help="generated functions to list")
    ap.add_argument("--stretches", type=int, default=6, help="stretches of code per function")
    ap.add_argument("--out", help="folder for the counts and listings (default: a new one)")
    args = ap.parse_args(argv)
    out = os.path.abspath(args.out or tempfile.mkdtemp(prefix="jit-profile-"))
    os.makedirs(out, exist_ok=True)
    binary = os.path.abspath(args.binary)
    env = dict(os.environ, RAYON_NUM_THREADS="1", LP_NUM_THREADS="1")
    command = lambda spp: [
        binary, "render", args.scene, "--device", "gpu", "--spp", str(spp),
        "--width", str(args.size), "--height", str(args.size),
        "-o", os.path.join(out, "render.exr"), *render,
    ]
    subprocess.run(
        ["valgrind", "--tool=none", "--smc-check=all", *command(1)],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    script = os.path.join(out, "gdb.txt")
    with open(script, "w") as f:
        f.write(
            "set pagination off\nset confirm off\nset breakpoint pending on\n"
            "target remote | vgdb --pid=PID\n"
            f"break pipelines.rs:{breakpoint_line()}\ncontinue\n"
            f"python import sys; sys.path.insert(0, {os.path.dirname(os.path.abspath(__file__))!r})\n"
            f"python import jit_profile; jit_profile.gdb_dump({out!r}, {args.top})\n"
            "kill\n"
        )
    log = open(os.path.join(out, "valgrind.log"), "w")
    program = subprocess.Popen(
        ["valgrind", "--tool=callgrind", "--smc-check=all", "--dump-instr=yes", "--vgdb=yes",
         "--vgdb-error=0", f"--callgrind-out-file={os.path.join(out, 'callgrind.out')}",
         *command(args.spp)],
        env=env, stdout=log, stderr=subprocess.STDOUT,
    )
    with open(script) as f:
        text = f.read().replace("PID", str(program.pid))
    with open(script, "w") as f:
        f.write(text)
    time.sleep(2)  # valgrind's gdb server starts with the program
    gdb = subprocess.run(
        ["gdb", "-batch", "-x", script, binary],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    program.wait()
    with open(os.path.join(out, "gdb.log"), "w") as f:
        f.write(gdb.stdout)
    found = os.path.join(out, "jit.json")
    if not os.path.exists(found):
        sys.exit(f"jit_profile: gdb copied no code (logs in {out}):\n{gdb.stdout[-2000:]}")
    with open(found) as f:
        jit = json.load(f)
    cost = collections.defaultdict(int)
    for (_, _, a), ir in parse_callgrind(jit["callgrind"]).items():
        cost[a] += ir
    samples = args.size * args.size * args.spp
    print(f"lavapipe's generated functions, {os.path.basename(args.scene)} at {args.size}², "
          f"{args.spp} spp, one llvmpipe thread; listings in {out}")
    for func in jit["functions"]:
        rows = listing(func, cost)
        with open(os.path.join(out, "fn-%x.txt" % func["low"]), "w") as f:
            for c, a, ins in rows:
                f.write("%12d  %x  %s\n" % (c, a, ins))
        calls = sum(1 for c, _, ins in rows if c and ins.startswith("call"))
        print(f"\nfunction at {func['low']:#x}: {func['instructions']:,} instructions, "
              f"{func['instructions'] / samples:,.0f} per sample; {len(rows)} instructions long, "
              f"{calls} call sites run")
        # Stretches: instructions that ran equally often (a loop body, a run between branches).
        stretch = collections.defaultdict(lambda: [0, 0])
        for c, _, _ in rows:
            if c:
                stretch[c][0] += 1
                stretch[c][1] += c
        for c, (n, total) in sorted(stretch.items(), key=lambda kv: -kv[1][1])[: args.stretches]:
            print(f"  {n:5d} instructions run {c:9,d} times: {total / func['instructions']:6.1%}")


if __name__ == "__main__":
    main()
