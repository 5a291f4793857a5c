#!/bin/bash
# Runs a command with the lavapipe of Mesa 25 (Debian bookworm-backports), which has
# VK_EXT_mesh_shader, so that mdstream's task/mesh sprite path runs on a machine without a GPU.
# Debian 12's own lavapipe (Mesa 22.3, what tools/bootstrap.sh installs and CI uses) has no mesh
# shaders. Nothing on the system changes: the packages are fetched with `apt-get download` and
# unpacked into a private folder, and only the command below sees them (VK_ICD_FILENAMES,
# LD_LIBRARY_PATH). With that driver `--mesh-shaders auto` picks the mesh path, so the whole
# test suite exercises it.
#
#   bash tools/mesh_lavapipe.sh                       # the test suite of build/ on the mesh path
#   bash tools/mesh_lavapipe.sh ./build/mdstream render out/porous.mds -o m.png --mesh-shaders on
#   bash tools/mesh_lavapipe.sh --fetch               # only fetch (tools/bootstrap.sh --mesh-lavapipe)
#   bash tools/mesh_lavapipe.sh --if-present CMD...   # exit 77 (CTest: skipped) when not fetched
#
# MESH_LAVAPIPE_DIR (default build/mesa-lavapipe) holds the unpacked driver; it is reused.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
dir=${MESH_LAVAPIPE_DIR:-$repo/build/mesa-lavapipe}
arch=$(dpkg --print-architecture)
multiarch=$(dpkg-architecture -qDEB_HOST_MULTIARCH 2>/dev/null || echo x86_64-linux-gnu)
icd=$dir/lvp_icd.json
lib=$dir/root/usr/lib/$multiarch

mode=run
case "${1:-}" in
  --fetch) mode=fetch; shift ;;
  --if-present) mode=if-present; shift ;;
esac
if [ "$mode" = if-present ] && [ ! -f "$icd" ]; then
  echo "mesh_lavapipe.sh: Mesa 25's lavapipe is not in $dir (bash tools/bootstrap.sh --mesh-lavapipe fetches it): skipped" >&2
  exit 77
fi

if [ ! -f "$icd" ]; then
  . /etc/os-release
  if [ "${VERSION_CODENAME:-}" != bookworm ]; then
    echo "mesh_lavapipe.sh: made for Debian 12 (bookworm), this is ${PRETTY_NAME:-unknown}" >&2
    exit 2
  fi
  mkdir -p "$dir/apt/lists/partial" "$dir/apt/cache/archives/partial" "$dir/debs"
  # deb822 source with the archive key, so the backports index is verified as apt verifies its own.
  cat > "$dir/apt/backports.sources" <<EOF
Types: deb
URIs: http://deb.debian.org/debian
Suites: bookworm-backports
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
EOF
  apt_opts=(-o Dir::Etc::sourcelist=/dev/null -o "Dir::Etc::sourceparts=$dir/apt"
            -o "Dir::State::Lists=$dir/apt/lists" -o "Dir::Cache=$dir/apt/cache"
            -o Dir::State::status=/var/lib/dpkg/status -o APT::Sandbox::User=root -q)
  # Only files ending in .sources / .list under sourceparts are read.
  apt-get "${apt_opts[@]}" update >/dev/null
  # The driver and the libdrm it needs (newer than bookworm's); libllvm15 and the rest are
  # bookworm's own (installed with mesa-vulkan-drivers by tools/bootstrap.sh).
  (cd "$dir/debs" && apt-get "${apt_opts[@]}" download \
    "mesa-vulkan-drivers:$arch/bookworm-backports" "libdrm2:$arch/bookworm-backports" \
    "libdrm-amdgpu1:$arch/bookworm-backports" >/dev/null)
  rm -rf "$dir/root"
  for deb in "$dir"/debs/*.deb; do dpkg-deb -x "$deb" "$dir/root"; done
  [ -f "$lib/libvulkan_lvp.so" ] || { echo "mesh_lavapipe.sh: no libvulkan_lvp.so in the package" >&2; exit 1; }
  # The package's manifest, with the library's absolute path.
  sed "s#\"library_path\": *\"[^\"]*\"#\"library_path\": \"$lib/libvulkan_lvp.so\"#" \
    "$dir/root/usr/share/vulkan/icd.d/lvp_icd.json" > "$icd.tmp"
  mv "$icd.tmp" "$icd"
  echo "mesh_lavapipe.sh: $(ls "$dir"/debs | tr '\n' ' ')-> $dir" >&2
fi

[ "$mode" = fetch ] && exit 0
export VK_ICD_FILENAMES=$icd
export MDSTREAM_REQUIRE_MESH_SHADERS=1  # tests/test_mesh_sprites.cpp fails if the driver has none
export MDSTREAM_PREFER_MESH=1  # --mesh-shaders auto takes the mesh path (render/mesh_sprites.h)
export LD_LIBRARY_PATH=$lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
if [ $# -eq 0 ]; then
  exec ctest --test-dir "$repo/build" --output-on-failure -j2
fi
exec "$@"
