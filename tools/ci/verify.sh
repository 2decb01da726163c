#!/usr/bin/env bash
# What the GitHub Action (action.yml) and the GitLab template (tools/ci/gitlab-ci.yml) run in a
# user's repository: `wavetrace verify` of the scenes the user names, its HTML report, JUnit and
# JSON in one folder, then a summary for the CI system (tools/ci/summary.py). Exit status:
# verify's (0 all agree, 1 one differs or cannot be judged, 2 usage error).
#
#   tools/ci/verify.sh [--report DIR] [--] SCENE_OR_GLOB... [-- VERIFY_ARGS...]
#
#   WAVETRACE   the binary (default: wavetrace on PATH)
#   GITHUB_STEP_SUMMARY, GITHUB_ACTIONS   set by GitHub: a Markdown table is appended to the
#               summary and each failing scene becomes an `::error file=…` annotation
#
# Scene arguments may be globs (quoted, so that the CI's YAML passes them through): each is
# expanded here, relative to the working folder; one that matches nothing is an error.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
wavetrace=${WAVETRACE:-wavetrace}
report=wavetrace-verify
scenes=() extra=()
while [ $# -gt 0 ]; do
    case $1 in
        --report) report=$2; shift 2 ;;
        --) shift; break ;;
        *) break ;;
    esac
done
while [ $# -gt 0 ] && [ "$1" != -- ]; do
    # A pattern (with * ? [) is expanded; a plain path is kept as given, so that verify names
    # a missing file itself.
    if [[ $1 == *[\*\?\[]* ]]; then
        shopt -s nullglob globstar
        matches=($1)
        shopt -u nullglob globstar
        if [ ${#matches[@]} -eq 0 ]; then
            echo "tools/ci/verify.sh: no scene matches $1" >&2
            exit 2
        fi
        scenes+=("${matches[@]}")
    else
        scenes+=("$1")
    fi
    shift
done
[ $# -gt 0 ] && shift
extra=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
    echo "tools/ci/verify.sh: name the scenes to verify (paths or quoted globs)" >&2
    exit 2
fi
mkdir -p "$report"
status=0
"$wavetrace" verify "${scenes[@]}" "${extra[@]}" --report "$report" \
    --junit "$report/junit.xml" --json "$report/verify.json" || status=$?
if [ -f "$report/verify.json" ]; then
    python3 "$here/summary.py" "$report/verify.json" || true
fi
exit $status
