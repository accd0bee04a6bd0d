#!/usr/bin/env bash
# Installs what unicac needs on a fresh Debian 12 machine and checks the Rust toolchain (g++: the
# kernels of `unicac-train train --compile on`).
# Idempotent: apt runs only when a package is missing. Sourced by demo.sh and test.sh.
set -euo pipefail

APT_PACKAGES=(pkg-config g++ libfontconfig1-dev libfreetype-dev fonts-dejavu-core mesa-vulkan-drivers libvulkan1 python3-venv)
MIN_RUST_MINOR=89   # workspace rust-version 1.89 (AVX-512 target features, pulp x86-v4)

missing=()
for package in "${APT_PACKAGES[@]}"; do
  dpkg -s "$package" >/dev/null 2>&1 || missing+=("$package")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]} (apt)"
  if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# Mesa's Vulkan drivers (lavapipe, for the GPU tests) probe Wayland and print errors when this is unset.
[ -n "${XDG_RUNTIME_DIR:-}" ] || { XDG_RUNTIME_DIR=$(mktemp -d); export XDG_RUNTIME_DIR; }

if ! command -v cargo >/dev/null 2>&1; then
  [ -x "$HOME/.cargo/bin/cargo" ] && export PATH="$HOME/.cargo/bin:$PATH"
fi
if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo not found; install Rust 1.$MIN_RUST_MINOR or newer (https://rustup.rs) and retry" >&2
  exit 1
fi
minor=$(rustc --version | sed -E 's/rustc 1\.([0-9]+).*/\1/')
if [ "$minor" -lt "$MIN_RUST_MINOR" ]; then
  echo "setup: rustc 1.$minor is too old; unicac needs 1.$MIN_RUST_MINOR or newer" >&2
  exit 1
fi
