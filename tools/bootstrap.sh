#!/usr/bin/env bash
# Installs every Debian package mdstream needs to build, test and run.
# Idempotent: when everything is present it only checks (a few seconds) and exits.
#   --mesh-lavapipe  also fetch Mesa 25's lavapipe (bookworm-backports), which has mesh shaders,
#                    into build/mesa-lavapipe without installing it (tools/mesh_lavapipe.sh): the
#                    test suite then also runs the task/mesh sprite path. Best effort: a failed
#                    fetch is a warning, and those tests report themselves skipped.
set -euo pipefail
mesh_lavapipe=0
for arg in "$@"; do
  case "$arg" in
    --mesh-lavapipe) mesh_lavapipe=1 ;;
    *) echo "bootstrap: unknown option $arg (expected --mesh-lavapipe)" >&2; exit 2 ;;
  esac
done
fetch_mesh_lavapipe() {
  [ "$mesh_lavapipe" = 1 ] || return 0
  if ! bash "$(dirname "$0")/mesh_lavapipe.sh" --fetch; then
    echo "bootstrap: warning: could not fetch Mesa 25's lavapipe; the mesh-path tests will be skipped" >&2
  fi
}

PACKAGES=(
  # toolchain
  build-essential cmake pkg-config git
  # Vulkan: loader, headers, lavapipe (software ICD), shader compiler
  libvulkan-dev mesa-vulkan-drivers glslang-tools vulkan-tools vulkan-validationlayers
  # maths, formats, compression
  libglm-dev libhdf5-dev liblz4-dev libxxhash-dev libzstd-dev zlib1g-dev libpng-dev libtinyexr-dev
  # meshlet construction (kd-tree / octree): PCL, and FLANN, the kd-tree under pcl::KdTreeFLANN,
  # whose index the PCL builder queries one point at a time (preprocess/pcl/meshlet_pcl.cpp)
  libpcl-dev libflann-dev
  # CLI, JSON, logging
  libcli11-dev nlohmann-json3-dev libfmt-dev libspdlog-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # viewer: window + X11 testing
  libglfw3-dev xvfb xdotool x11-apps libstb-dev
  # real inputs and references for tests and tools
  lammps python3 python3-numpy python3-scipy python3-h5py python3-mdanalysis python3-matplotlib
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "bootstrap: all ${#PACKAGES[@]} packages present"
  fetch_mesh_lavapipe
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "bootstrap: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y --no-install-recommends -qq "${missing[@]}"
fetch_mesh_lavapipe
echo "bootstrap: done"
