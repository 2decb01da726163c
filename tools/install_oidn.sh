#!/usr/bin/env bash
# Installs Intel Open Image Denoise 2.5.1's shared libraries for the current user, no root
# needed, for wavetrace's denoiser (src/denoise.rs loads them at run time).
#
#   bash tools/install_oidn.sh
#
# The libraries come from the pyoidn 2.5.1.0 wheel on PyPI, which ships OIDN's official Linux
# x86-64 build (CPU and CUDA device modules, TBB). Only the wheel is downloaded (`pip download`,
# which PEP 668 "externally managed" Pythons allow); nothing is pip-installed. The wheel's
# pyoidn/oidn/lib/* goes to
#   ${WAVETRACE_OIDN_HOME:-${XDG_DATA_HOME:-$HOME/.local/share}/wavetrace/oidn}/lib
# which is where wavetrace looks after $WAVETRACE_OIDN. Running it again does nothing once that
# version is installed; FORCE=1 reinstalls.
set -euo pipefail

OIDN_VERSION=2.5.1
WHEEL_SPEC="pyoidn==${OIDN_VERSION}.0"
# SYCL (Intel GPU) and HIP (AMD GPU) modules and their runtimes are ~75 MB that wavetrace's
# targets (CPU, NVIDIA) do not use; KEEP_ALL=1 installs them too.
SKIP_PATTERN='^(libOpenImageDenoise_device_(sycl|hip)\.|libsycl\.|libur_|libumf\.)'

# A relative XDG_DATA_HOME is invalid per the XDG spec and ignored, as src/denoise.rs does.
DATA_HOME="${XDG_DATA_HOME:-}"
[[ "$DATA_HOME" == /* ]] || DATA_HOME="$HOME/.local/share"
PREFIX="${WAVETRACE_OIDN_HOME:-$DATA_HOME/wavetrace/oidn}"
LIBDIR="$PREFIX/lib"
STAMP="$LIBDIR/.wavetrace-oidn-version"

say() { printf 'install_oidn: %s\n' "$*"; }
die() { printf 'install_oidn: error: %s\n' "$*" >&2; exit 1; }

case "$(uname -s)/$(uname -m)" in
  Linux/x86_64) ;;
  *) die "only Linux x86-64 is supported (the wheel is manylinux x86_64); this is $(uname -s)/$(uname -m)" ;;
esac

explain() {
  say "how wavetrace finds it: \$WAVETRACE_OIDN (a folder with libOpenImageDenoise.so.2, or the file)"
  say "  if set, else \$WAVETRACE_OIDN_HOME/lib, else \${XDG_DATA_HOME:-\$HOME/.local/share}/wavetrace/oidn/lib,"
  say "  else the system loader's search for libOpenImageDenoise.so.2."
  if [[ -n "${WAVETRACE_OIDN_HOME:-}" ]]; then
    say "  WAVETRACE_OIDN_HOME is set here; the same value (or WAVETRACE_OIDN=$LIBDIR) must be set when running wavetrace."
  fi
}

if [[ "${FORCE:-0}" != 1 && -f "$STAMP" && "$(cat "$STAMP")" == "$OIDN_VERSION" \
      && -f "$LIBDIR/libOpenImageDenoise.so.2" ]]; then
  say "Open Image Denoise $OIDN_VERSION is already installed in $LIBDIR (FORCE=1 reinstalls)"
  explain
  exit 0
fi

# A Python with pip, to fetch the wheel from PyPI.
PYTHON="${PYTHON:-python3}"
command -v "$PYTHON" >/dev/null 2>&1 || die "python3 not found (Debian/Ubuntu: apt-get install -y python3-pip)"
if ! "$PYTHON" -m pip --version >/dev/null 2>&1; then
  if [[ "$(id -u)" == 0 ]] && command -v apt-get >/dev/null 2>&1; then
    say "pip is missing; installing python3-pip with apt-get"
    DEBIAN_FRONTEND=noninteractive apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-pip >/dev/null
    "$PYTHON" -m pip --version >/dev/null 2>&1 \
      || die "python3-pip is installed but $PYTHON still has no pip; run with PYTHON=/usr/bin/python3"
  else
    die "pip is missing for $PYTHON. Install it (Debian/Ubuntu: sudo apt-get install -y python3-pip), or run with PYTHON=/path/to/a/python that has pip."
  fi
fi

WORK="$(mktemp -d "${TMPDIR:-/tmp}/wavetrace-oidn.XXXXXX")"
trap 'rm -rf "$WORK"' EXIT

say "downloading $WHEEL_SPEC from PyPI (about 90 MB)"
"$PYTHON" -m pip download --quiet --no-deps --only-binary=:all: --dest "$WORK" "$WHEEL_SPEC" \
  || die "pip download $WHEEL_SPEC failed (is PyPI reachable? a proxy needs HTTPS_PROXY)"
WHEEL="$(ls "$WORK"/pyoidn-*.whl 2>/dev/null | head -n 1)"
[[ -n "$WHEEL" ]] || die "pip download left no pyoidn wheel in $WORK"

# Extract pyoidn/oidn/lib/* (files only; the wheel stores each soname as a full copy, not as
# symlinks) into a staging folder next to the target, then swap it in, so an interrupted run
# never leaves a half-written install behind.
STAGE="$PREFIX/.lib.new.$$"
rm -rf "$STAGE"
mkdir -p "$STAGE"
"$PYTHON" - "$WHEEL" "$STAGE" "${KEEP_ALL:-0}" "$SKIP_PATTERN" <<'EOF'
import os, re, shutil, sys, zipfile
wheel, dest, keep_all, skip = sys.argv[1], sys.argv[2], sys.argv[3] == "1", re.compile(sys.argv[4])
prefix = "pyoidn/oidn/lib/"
count = 0
with zipfile.ZipFile(wheel) as z:
    for info in z.infolist():
        name = info.filename
        if not name.startswith(prefix) or name.endswith("/"):
            continue
        rel = name[len(prefix):]
        # Only the libraries themselves; lib/cmake/ is for building against OIDN.
        if "/" in rel or (not keep_all and skip.match(rel)):
            continue
        target = os.path.join(dest, rel)
        with z.open(info) as src, open(target, "wb") as dst:
            shutil.copyfileobj(src, dst)
        os.chmod(target, 0o755)
        count += 1
if count == 0:
    sys.exit("no libraries under " + prefix + " in " + wheel)
print(f"install_oidn: extracted {count} files")
EOF
[[ -f "$STAGE/libOpenImageDenoise.so.2" ]] || die "the wheel had no libOpenImageDenoise.so.2"
printf '%s\n' "$OIDN_VERSION" > "$STAGE/.wavetrace-oidn-version"

rm -rf "$LIBDIR.old"
[[ -e "$LIBDIR" ]] && mv "$LIBDIR" "$LIBDIR.old"
mv "$STAGE" "$LIBDIR"
rm -rf "$LIBDIR.old"

say "installed Open Image Denoise $OIDN_VERSION in $LIBDIR ($(du -sh "$LIBDIR" | cut -f1))"
say "library: $LIBDIR/libOpenImageDenoise.so.2"
explain
