#!/bin/bash
# Copies a build's mdstream, its modules and chosen test executables, with every shared library they
# load except glibc's, into DIR/bin, DIR/tests and DIR/lib, so that they run on an x86-64 machine
# that has a Vulkan driver but not this build's Debian packages (a GPU machine with a CUDA image,
# say). Run them there with LD_LIBRARY_PATH=DIR/lib; tools/gpu_check.sh does that.
#
#   bash tools/portable_bundle.sh BUILD_DIR DIR [test_name ...]
#
# With MDSTREAM_BUNDLE_VALIDATION=1 the Khronos validation layer (22 MB) goes into DIR/layers too
# (VK_LAYER_PATH=DIR/layers finds it; the test suites turn it on wherever it is found).
#
# The executables need glibc >= 2.34 (objdump -T shows no newer symbol version) and a Vulkan loader
# (libvulkan.so.1 is bundled; the driver's ICD file is the machine's own).
set -euo pipefail
build=${1:?usage: portable_bundle.sh BUILD_DIR DIR [test_name ...]}
dir=${2:?usage: portable_bundle.sh BUILD_DIR DIR [test_name ...]}
shift 2
rm -rf "$dir"
mkdir -p "$dir/bin" "$dir/tests" "$dir/lib"
cp "$build/mdstream" "$build"/libmdstream_*.so "$dir/bin/"
for t in "$@"; do cp "$build/tests/$t" "$dir/tests/"; done
# ldd's closure of everything copied, less the C library, its loader and its split-off parts.
for f in "$dir"/bin/* "$dir"/tests/*; do
  [ -f "$f" ] || continue
  ldd "$f" | awk '$2 == "=>" && $3 ~ /^\// {print $3}'
done | sort -u | while read -r lib; do
  case "$(basename "$lib")" in
    libc.so.*|libm.so.*|libdl.so.*|libpthread.so.*|librt.so.*|ld-linux*|libresolv.so.*) ;;
    *) cp -L "$lib" "$dir/lib/" ;;
  esac
done
if [ "${MDSTREAM_BUNDLE_VALIDATION:-0}" = 1 ]; then
  mkdir -p "$dir/layers"
  json=/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json
  lib=$(sed -n 's/.*"library_path": *"\([^"]*\)".*/\1/p' "$json")
  found=""
  for d in /usr/lib/x86_64-linux-gnu /usr/lib64 /usr/lib /usr/local/lib; do
    [ -f "$d/$(basename "$lib")" ] && { found="$d/$(basename "$lib")"; break; }
  done
  [ -n "$found" ] || { echo "portable_bundle: $(basename "$lib") (from $json) not found" >&2; exit 1; }
  cp -L "$found" "$dir/layers/"
  sed 's|"library_path": *"[^"]*"|"library_path": "./'"$(basename "$lib")"'"|' "$json" > "$dir/layers/$(basename "$json")"
fi
# The test executables name the source folder and build/mdstream by absolute path.
sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt" > "$dir/source_dir"
strip --strip-unneeded "$dir"/bin/* "$dir"/tests/* 2>/dev/null || true
du -sh "$dir"
