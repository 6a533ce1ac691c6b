#!/usr/bin/env bash
# The GPU step's compile check (docs/gpu.md), run by .ci/run after the test suite: CI has no GPU,
# so this builds the CUDA code with Debian's own toolkit (nvidia-cuda-toolkit 11.8 from
# bookworm's non-free component, host compiler clang++-14) and runs the GPU test executable,
# whose GPU comparisons skip there, saying why, while its arithmetic tests run. README command 2
# (tests/run.sh) stays CUDA-free. BUILD_DIR picks the build directory (default: build-cuda).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build-cuda}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
# The toolkit: Debian's (installed here unless present), else, if that cannot be installed,
# NVIDIA's in /usr/local/cuda where the machine has one (with its default host compiler).
nvcc=/usr/bin/nvcc
host=(-DCMAKE_CUDA_HOST_COMPILER=clang++-14)
if ! [ -x /usr/bin/nvcc ] || ! command -v clang++-14 > /dev/null; then
    echo "cuda-build: installing nvidia-cuda-toolkit (non-free) and clang-14"
    $SUDO tee /etc/apt/sources.list.d/medial-elastics-non-free.sources > /dev/null <<'SOURCES'
Types: deb
URIs: http://deb.debian.org/debian
Suites: bookworm bookworm-updates
Components: contrib non-free
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SOURCES
    export DEBIAN_FRONTEND=noninteractive
    if ! { $SUDO apt-get update -qq \
        && $SUDO apt-get install -y -qq --no-install-recommends nvidia-cuda-toolkit clang-14 \
            > /dev/null; }; then
        if [ -x /usr/local/cuda/bin/nvcc ]; then
            echo "cuda-build: Debian's toolkit could not be installed; using /usr/local/cuda"
            nvcc=/usr/local/cuda/bin/nvcc
            host=()
        else
            echo "cuda-build: no CUDA toolkit: Debian's nvidia-cuda-toolkit could not be installed" >&2
            exit 1
        fi
    fi
fi
if [ "$nvcc" = /usr/bin/nvcc ]; then
    # Debian's nvcc runs ptxas, fatbinary, nvlink and cudafe++ from PATH: its own, in /usr/bin,
    # must come before any other toolkit's (a machine with NVIDIA's CUDA 13 in /usr/local has
    # wrappers of the same names in /usr/local/bin, and CUDA 13's ptxas rejects 11.8's default
    # architecture).
    export PATH="/usr/bin:/bin:$PATH"
fi
echo "cuda-build: $("$nvcc" --version | tail -1)"
start=$(date +%s)
mkdir -p "$build"
cmake -S "$root" -B "$build" -DMAT_CUDA=ON -DCMAKE_CUDA_COMPILER="$nvcc" "${host[@]}" \
    > "$build/configure.log" 2>&1 || { cat "$build/configure.log"; exit 1; }
cmake --build "$build" -j"$(nproc)" --target mat-run test_runtime_gpu gpu_bench
"$build/tests/test_runtime_gpu"
echo "cuda-build: built and tested in $(($(date +%s) - start)) s"
