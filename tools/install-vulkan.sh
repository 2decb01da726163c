#!/usr/bin/env bash
# Installs what a fresh Debian/Ubuntu machine lacks for wavetrace: the Vulkan loader, Mesa's
# software Vulkan driver (lavapipe), where packaged the Khronos validation layers, and the C++
# compiler the build needs (the glslang crate compiles glslang from source).
# On Debian 12 (bookworm) Mesa 22.3.6 has known lavapipe crashes, so Mesa comes from
# bookworm-backports there. Idempotent: does nothing when all of it is already installed.
set -euo pipefail

have_driver() {
  local libs
  libs=$(ldconfig -p 2>/dev/null || /sbin/ldconfig -p 2>/dev/null || true)
  [[ $libs == *libvulkan.so.1* ]] &&
    { compgen -G '/usr/share/vulkan/icd.d/*.json' || compgen -G '/etc/vulkan/icd.d/*.json'; } >/dev/null
}
have_layers() {
  compgen -G '/usr/share/vulkan/explicit_layer.d/*validation*.json' >/dev/null
}
have_compiler() {
  command -v c++ >/dev/null 2>&1
}

if have_driver && have_compiler && { have_layers || [ "${WAVETRACE_NEED_LAYERS:-0}" = 0 ]; }; then
  echo "install-vulkan: a Vulkan loader, a driver and a C++ compiler are already installed"
  exit 0
fi

sudo=""
if [ "$(id -u)" != 0 ]; then sudo="sudo"; fi
export DEBIAN_FRONTEND=noninteractive

. /etc/os-release
suite=()
if [ "${ID:-}" = debian ] && [ "${VERSION_CODENAME:-}" = bookworm ]; then
  list=/etc/apt/sources.list.d/wavetrace-bookworm-backports.list
  if ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
    echo "deb http://deb.debian.org/debian bookworm-backports main" | $sudo tee "$list" >/dev/null
  fi
  suite=(-t bookworm-backports)
fi

$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${suite[@]}" mesa-vulkan-drivers libvulkan1
have_compiler || $sudo apt-get install -y -qq --no-install-recommends g++
# The validation layers are optional at run time; tests enable them when they are installed.
$sudo apt-get install -y -qq --no-install-recommends vulkan-validationlayers ||
  echo "install-vulkan: vulkan-validationlayers is not packaged here; tests run without it"
echo "install-vulkan: done"
