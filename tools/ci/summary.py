#!/usr/bin/env python3
"""What a CI system shows of `wavetrace verify`'s JSON report (report_version 2):

- a Markdown table, one row per scene (verdict, what failed, seconds), appended to the file
  $GITHUB_STEP_SUMMARY names (GitHub Actions' job summary), or printed where it is unset;
- on GitHub Actions ($GITHUB_ACTIONS=true), an `::error file=SCENE::message` workflow command
  per failing scene, which GitHub shows as an annotation on the scene's file.

    python3 tools/ci/summary.py REPORT/verify.json

Python 3 standard library only; always exits 0 (verify's own exit status is the verdict).
"""

import json
import os
import sys


def escape_annotation(text):
    # Workflow command data: %, CR and LF are escaped (GitHub's "workflow commands" reference).
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def escape_property(text):
    # A workflow command's property value also escapes ':' and ','.
    return escape_annotation(text).replace(":", "%3A").replace(",", "%2C")


def escape_cell(text):
    return text.replace("|", "\\|").replace("\n", " ")


def what_failed(scene):
    if "error" in scene:
        return "error: " + scene["error"].splitlines()[0]
    if "flip" in scene:
        f = scene["flip"]
        return "mean FLIP %.4f (at most %s)" % (f["mean"], f["max_allowed"])
    failures = len(scene.get("failures", []))
    return "%d of %d tile tests reject" % (failures, scene.get("tests", 0))


def main(path):
    with open(path) as f:
        report = json.load(f)
    scenes = report.get("scenes", [])
    agree = sum(1 for s in scenes if s.get("passed"))
    lines = [
        "### wavetrace verify: %d of %d scenes agree" % (agree, len(scenes)),
        "",
        "wavetrace %s on %s" % (report.get("wavetrace_version", "?"), report.get("device", "?")),
        "",
        "| scene | verdict | detail | seconds |",
        "|---|---|---|---|",
    ]
    for s in scenes:
        verdict = "pass" if s.get("passed") else ("error" if "error" in s else "FAIL")
        lines.append("| %s | %s | %s | %s |" % (
            escape_cell(s["scene"]), verdict, escape_cell(what_failed(s)),
            "%.2f" % s["seconds"] if "seconds" in s else ""))
    table = "\n".join(lines) + "\n"
    summary = os.environ.get("GITHUB_STEP_SUMMARY")
    if summary:
        with open(summary, "a") as f:
            f.write(table)
    else:
        sys.stdout.write(table)
    if os.environ.get("GITHUB_ACTIONS") == "true":
        for s in scenes:
            if not s.get("passed"):
                print("::error file=%s,title=wavetrace verify::%s" % (
                    escape_property(s["scene"]), escape_annotation(what_failed(s))))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
