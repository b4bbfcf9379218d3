#!/usr/bin/env bash
# Installs everything relight needs on Debian 12 (as root, or with sudo).
# Skips packages that are already installed, so it is cheap to rerun.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config git
  # libraries (all found by CMake's find_package)
  libeigen3-dev libyaml-cpp-dev nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev libssl-dev
  libtbb-dev libopenimageio-dev openimageio-tools libembree-dev libceres-dev libcgal-dev libopencv-dev
  libgtest-dev libgmock-dev libbenchmark-dev libsqlite3-dev libtinygltf-dev
  # programs the stages drive, and data
  colmap gnuplot-nox blender-data
  # headless browser for the report test
  chromium
  # Blender, for the test that imports the glTF export (modules/relight/gltf_blender_test.cc); the test's
  # scripts use NumPy in Blender's Python, which Debian's blender only recommends
  blender python3-numpy
  # Slurm and munge: pipeline.executor slurm and its test on a single-node cluster (tools/slurm_local_cluster.sh)
  slurmctld slurmd slurm-client munge
  # libFuzzer and the sanitizers for the parser fuzz targets (fuzz/)
  clang libclang-rt-14-dev
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} Debian packages are installed"
  exit 0
fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then
    sudo_cmd=(sudo)
  else
    echo "setup: need root to install: ${missing[*]}" >&2
    echo "setup: rerun as root, or install them with your package manager" >&2
    exit 1
  fi
fi
echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
