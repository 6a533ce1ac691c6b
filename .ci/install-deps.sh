#!/usr/bin/env bash
# Installs every package the project needs, from Debian 12 only, then extracts the two
# real test meshes (armadillo.off, bunny00.off) from libcgal-demo into samples/meshes/.
# Safe to run again: apt-get skips what is installed, extraction is skipped when present.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

packages=(
    ca-certificates g++ make cmake pkg-config git
    libcgal-dev libcgal-demo libgmp-dev libmpfr-dev libboost-dev
    libeigen3-dev
    libsuitesparse-dev libopenblas0-pthread
    libassimp-dev
    libhdf5-dev
    libcli11-dev libtbb-dev libspdlog-dev nlohmann-json3-dev libstb-dev
    libgtest-dev libbenchmark-dev
    clang-format
)

missing=()
for p in "${packages[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing+=("$p")
    fi
done
if [ "${#missing[@]}" -gt 0 ]; then
    echo "install-deps: installing ${#missing[@]} package(s): ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
    echo "install-deps: all ${#packages[@]} packages already installed"
fi

# Real closed meshes ship in libcgal-demo; they are extracted, never committed.
meshes="$here/samples/meshes"
archive=/usr/share/doc/libcgal-dev/data.tar.gz
mkdir -p "$meshes"
for m in armadillo bunny00; do
    if [ ! -s "$meshes/$m.off" ]; then
        tar -xzf "$archive" -O "data/meshes/$m.off" > "$meshes/$m.off.tmp"
        mv "$meshes/$m.off.tmp" "$meshes/$m.off"
    fi
done
echo "install-deps: real meshes in $meshes: $(ls "$meshes" | tr '\n' ' ')"
