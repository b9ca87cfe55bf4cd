#!/usr/bin/env bash
# Idempotent set-up: installs only what is missing. Both README commands run it first.
# A second run takes seconds: every step checks before it acts.
set -euo pipefail

NIGHTLY=nightly-2026-08-15
MESA_MIN_MAJOR=25

log() { printf 'setup: %s\n' "$*" >&2; }

as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}

# 1. The pinned nightly rust-gpu 0.11 needs, with the lint tools so checks run under it.
if ! rustup toolchain list | grep -q "^${NIGHTLY}"; then
  log "installing Rust ${NIGHTLY} (rust-gpu 0.11 needs exactly this one)"
  rustup toolchain install "${NIGHTLY}" --profile minimal \
    -c rust-src -c rustc-dev -c llvm-tools -c rustfmt -c clippy -t x86_64-unknown-none
else
  have=$(rustup component list --installed --toolchain "${NIGHTLY}" 2>/dev/null || true)
  for c in rust-src rustc-dev llvm-tools rustfmt clippy; do
    if ! grep -q "^${c}" <<<"${have}"; then
      log "adding component ${c} to ${NIGHTLY}"
      rustup component add --toolchain "${NIGHTLY}" "${c}"
    fi
  done
  # A bare-metal target proves the shared crate builds without std (CI checks it).
  if ! rustup target list --installed --toolchain "${NIGHTLY}" | grep -q '^x86_64-unknown-none$'; then
    log "adding target x86_64-unknown-none to ${NIGHTLY}"
    rustup target add --toolchain "${NIGHTLY}" x86_64-unknown-none
  fi
fi

# 2. Vulkan: loader, tools, validation layers, and lavapipe from Mesa >= 25 (ray queries).
mesa_major() {
  dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null | sed -E 's/^([0-9]+:)?([0-9]+).*/\2/'
}
pkg_ok() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q 'install ok installed'; }

need_apt=0
for p in libvulkan1 vulkan-tools vulkan-validationlayers; do pkg_ok "$p" || need_apt=1; done
m=$(mesa_major || true)
if [ -z "${m}" ] || [ "${m}" -lt "${MESA_MIN_MAJOR}" ]; then need_apt=1; fi

if [ "${need_apt}" -eq 1 ]; then
  if ! command -v apt-get >/dev/null; then
    log "error: apt-get not found; install libvulkan1, vulkan-validationlayers and Mesa >= ${MESA_MIN_MAJOR} lavapipe by hand"
    exit 1
  fi
  bp=/etc/apt/sources.list.d/bookworm-backports.sources
  if [ ! -f "${bp}" ]; then
    log "adding bookworm-backports (Mesa ${MESA_MIN_MAJOR}+ lavapipe has ray queries; bookworm's 22.3 does not)"
    src=/etc/apt/sources.list.d/debian.sources
    uris=$(grep -m1 '^URIs:' "${src}" 2>/dev/null | sed 's/^URIs: *//' || true)
    key=$(grep -m1 '^Signed-By:' "${src}" 2>/dev/null | sed 's/^Signed-By: *//' || true)
    as_root tee "${bp}" >/dev/null <<SRC
Types: deb
URIs: ${uris:-http://deb.debian.org/debian}
Suites: bookworm-backports
Components: main
Signed-By: ${key:-/usr/share/keyrings/debian-archive-keyring.gpg}
SRC
  fi
  log "installing Vulkan loader, tools, validation layers and lavapipe (apt)"
  as_root apt-get update -qq
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq -t bookworm-backports \
    mesa-vulkan-drivers libvulkan1 vulkan-tools >/dev/null
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq vulkan-validationlayers >/dev/null
  m=$(mesa_major || true)
  if [ -z "${m}" ] || [ "${m}" -lt "${MESA_MIN_MAJOR}" ]; then
    log "error: mesa-vulkan-drivers is ${m:-missing}, need >= ${MESA_MIN_MAJOR} (bookworm-backports)"
    exit 1
  fi
fi
# 3. `gi view` and its CI test: the X server Xvfb, and the X client libraries winit loads at run
# time (winit and softbuffer dlopen them: Xlib, Xlib-xcb, xcb, Xcursor, XInput2, Xrandr, xkbcommon).
x11_pkgs=(xvfb libx11-6 libx11-xcb1 libxcb1 libxcursor1 libxi6 libxrandr2 libxkbcommon0 libxkbcommon-x11-0)
missing=()
for p in "${x11_pkgs[@]}"; do pkg_ok "$p" || missing+=("$p"); done
if [ "${#missing[@]}" -gt 0 ]; then
  if ! command -v apt-get >/dev/null; then
    log "error: apt-get not found; install ${missing[*]} by hand"
    exit 1
  fi
  log "installing ${missing[*]} (apt)"
  as_root apt-get update -qq
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq "${missing[@]}" >/dev/null
fi
log "ok: ${NIGHTLY}, Mesa $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers)"
