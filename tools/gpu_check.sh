#!/bin/bash
# The GPU checks, in one run with a deadline, on a machine with a Vulkan GPU but without this
# project's Debian packages: a bundle made here by tools/portable_bundle.sh travels there.
#
#   bash tools/gpu_check.sh BUNDLE OUT [SECONDS]
#
# Steps, most important first, each cut off at the deadline (default 500 s from the start):
#   smoke  synth + convert + render of 100k particles; stops the run when the GPU is not the device
#   tests  the bundled GoogleTest suites (Vulkan ones), 4 at a time, the mesh path where the device
#          has VK_EXT_mesh_shader (`--mesh-shaders auto`)
#   tests_mesh  the same suites with MDSTREAM_PREFER_MESH=1 (`auto` takes the mesh path)
#   mesh   tools/bench_mesh_path.py (task/mesh path against compute + indirect draws, 1M particles)
#   big    tools/bench_mesh_path.py on 32M particles (porous) at 1920x1080
#   render tools/bench_render.py at 1920x1080, 32 spp, paired frames (issue 3's Tables 3 and 4),
#          the sprite path `--mesh-shaders auto` picks (compute + indirect draws)
#   render_mesh  the same with `--mesh-shaders on` (task/mesh path; fails without mesh shaders)
#   cache  tools/bench_cache.py, porous, fly-through and orbit, occlusion and LRU policies
#   cache_1m    tools/bench_cache.py, every scene, path and policy, at the setting of the lavapipe
#          run in docs/results/cache.md (1M particles, nodes of 1000, 320x180, 48 frames; ~50 s
#          on an H100)
#   cache_full  tools/bench_cache.py at its defaults (1.5M, nodes of 2000, 640x360; ~75 s)
#   classify  tools/bench_classify.py --variants subgroup,cells (the shared cells candidate,
#          docs/rendering.md) at 1M/320x180 and at its defaults (1.5M/640x360)
#   sweep  tools/bench_mesh_path.py (1M) at 640x360 and 1920x1080 under the pixel-route settings
#          MDSTREAM_PIXEL_ROUTE=attachments, MDSTREAM_SMALL_PX=0, =2 and the defaults (sweep/<cfg>_<w>)
# OUT gets log.txt (everything) and results.tar (each step's files, appended as the step ends, so
# a run cut off still returns the steps before). GPU_CHECK_GL_DEBS=DIR unpacks DIR/*.deb into / first
# (Debian's libvulkan1 and the glvnd libraries: without them the NVIDIA Vulkan driver of the lent
# H100 and H200 images returns no vkCreateInstance, VK_ERROR_INCOMPATIBLE_DRIVER; docs/rendering.md,
# "Checks on a GPU"). GPU_CHECK_STEPS="smoke tests" picks steps;
# GPU_CHECK_QUICK=1 makes every step small (a dry run of this script on lavapipe); PYTHON picks
# the interpreter.
set -uo pipefail
bundle=$(cd "${1:?usage: gpu_check.sh BUNDLE OUT [SECONDS]}" && pwd) || { echo "gpu_check: no bundle folder '$1'" >&2; exit 2; }
out=${2:?usage: gpu_check.sh BUNDLE OUT [SECONDS]}
budget=${3:-500}
steps=${GPU_CHECK_STEPS:-smoke tests tests_mesh mesh big render render_mesh cache sweep}
quick=${GPU_CHECK_QUICK:-0}
repo=$(cd "$(dirname "$0")/.." && pwd)
t0=$(date +%s)
mkdir -p "$out"
exec > >(tee -a "$out/log.txt") 2>&1
work=$(mktemp -d /tmp/gpu_check.XXXX)
left() { echo $((budget - ($(date +%s) - t0))); }
# step NAME LIMIT CMD...: runs CMD with min(LIMIT, time left), then appends $work/NAME to the tar.
step() {
  local name=$1 limit=$2; shift 2
  local l; l=$(left); [ "$limit" -gt "$l" ] && limit=$l
  if [ "$limit" -lt 15 ]; then echo "== $name: skipped, ${l} s left"; return 1; fi
  mkdir -p "$work/$name"
  echo "== $name (limit ${limit} s, $(date -u +%T))"
  local s; s=$(date +%s)
  STEP=$name timeout -k 5 "$limit" bash -c '"$@"' _ "$@"; local rc=$?
  echo "== $name: rc $rc, $(( $(date +%s) - s )) s"
  tar rf "$out/results.tar" -C "$work" "$name" 2>/dev/null
  return $rc
}

# The executables: where the build's test executables expect them (compile-time paths).
src_dir=$(cat "$bundle/source_dir" 2>/dev/null || echo "$repo")
mkdir -p "$repo/build/tests"
cp "$bundle"/bin/* "$repo/build/"
cp "$bundle"/tests/* "$repo/build/tests/" 2>/dev/null
if [ "$src_dir" != "$repo" ] && [ ! -e "$src_dir" ]; then mkdir -p "$(dirname "$src_dir")"; ln -s "$repo" "$src_dir"; fi
if [ -n "${GPU_CHECK_GL_DEBS:-}" ]; then
  for f in "$GPU_CHECK_GL_DEBS"/*.deb; do dpkg -x "$f" / || echo "gpu_check: dpkg -x $f failed"; done
  ldconfig
fi
export LD_LIBRARY_PATH="$bundle/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
for icd in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /usr/share/vulkan/icd.d/nvidia_icd.json \
           /etc/vulkan/icd.d/nvidia_icd.json; do
  if [ -f "$icd" ]; then export VK_DRIVER_FILES=$icd VK_ICD_FILENAMES=$icd; break; fi
done
[ -d "$bundle/layers" ] && export VK_LAYER_PATH="$bundle/layers"
export PYTHONUNBUFFERED=1
py=${PYTHON:-$(command -v python3)}  # needs numpy, pillow, matplotlib
mds="$repo/build/mdstream"
echo "repo $repo (tests built in $src_dir), bundle $bundle, python $py, ICD ${VK_ICD_FILENAMES:-none}"
nvidia-smi -L 2>/dev/null; nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv 2>/dev/null
grep -m1 "model name" /proc/cpuinfo; nproc; . /etc/os-release 2>/dev/null && echo "$PRETTY_NAME"

smoke() {
  cd "$work/smoke" || return 1
  "$mds" synth --scene porous -n 100000 -q -o s.lammpstrj && "$mds" convert s.lammpstrj -o s.mds >/dev/null &&
  "$mds" render s.mds -o s.png --width 320 --height 180 --spp 4 --stats s.json || return 1
  rm -f s.lammpstrj s.mds
  "$py" -c "import json; j = json.load(open('s.json')); print({k: j.get(k) for k in ('device', 'device_type', 'mesh_shader_available', 'sprite_path', 'culled_fraction', 'frame_ms_after_convergence')})"
  grep -q '"device_type": *"cpu"' s.json && [ "$quick" != 1 ] && { echo "the device is a CPU: stopping"; return 1; }
  return 0
}
tests() {
  cd "$work/$STEP" || return 1
  ls "$repo"/build/tests/ | xargs -P 4 -I{} sh -c \
    'timeout -k 5 '"$1"' "$0/build/tests/{}" --gtest_brief=1 > "{}.log" 2>&1; echo "{} rc $?"' "$repo"
  grep -h -e "^\[  FAILED" -e "^\[  PASSED" -e "SKIPPED \]" *.log | sort | uniq -c
}
tests_mesh() {
  MDSTREAM_PREFER_MESH=1 tests "$@"
}
sweep() {
  local cfg res
  for res in 640x360 1920x1080; do
    for cfg in attachments small0 small2 default; do
      [ "$quick" = 1 ] && [ "$cfg" != small2 ] && continue
      local env=()
      case $cfg in
        attachments) env=(MDSTREAM_PIXEL_ROUTE=attachments) ;;
        small0) env=(MDSTREAM_SMALL_PX=0) ;;
        small2) env=(MDSTREAM_SMALL_PX=2) ;;
      esac
      [ "$cfg" = default ] && [ "$res" = 640x360 ] && continue  # step mesh
      echo "sweep $cfg $res"
      env "${env[@]}" "$py" "$repo/tools/bench_mesh_path.py" $([ "$quick" = 1 ] && echo --quick) \
        --width "${res%x*}" --height "${res#*x}" --out "$work/sweep/${cfg}_${res%x*}" --work /tmp/gc_sweep || return 1
    done
  done
}
mesh() {
  local q=(); [ "$quick" = 1 ] && q=(--quick)
  "$py" "$repo/tools/bench_mesh_path.py" "${q[@]}" --out "$work/mesh" --work /tmp/gc_mesh
}
render() {
  local q=(--spp 32 --paired-frames 8); [ "$quick" = 1 ] && q=(--quick)
  "$py" "$repo/tools/bench_render.py" "${q[@]}" --out-dir "$work/render" --work-dir /tmp/gc_render
}
render_mesh() {
  local q=(--spp 32 --paired-frames 8); [ "$quick" = 1 ] && q=(--quick)
  "$py" "$repo/tools/bench_render.py" "${q[@]}" --render-args "--mesh-shaders on" --out-dir "$work/render_mesh" \
    --work-dir /tmp/gc_render
}
cache() {
  local q=(); [ "$quick" = 1 ] && q=(--quick)
  "$py" "$repo/tools/bench_cache.py" "${q[@]}" --scenes porous --paths flythrough,orbit --policies occlusion,lru \
    --no-scale --out "$work/cache" --work /tmp/gc_cache
}
# stress_jsons WORK DIR: the occlusion-policy stress JSONs of a cache run (per_frame.gpu_passes,
# cpu_parts, sample_route), xz-compressed into DIR (~0.4 MB instead of ~37: the lent machine
# returns a few files of limited size).
stress_jsons() {
  find "$1" -name '*occlusion*.json' | tar cJf "$2/stress_json.tar.xz" -T - 2>/dev/null
}
cache_1m() {
  local q=(--particles 1000000 --node-size 1000 --frames 48 --width 320 --height 180 --settle-frames 160)
  [ "$quick" = 1 ] && q=(--quick)
  "$py" "$repo/tools/bench_cache.py" "${q[@]}" --out "$work/cache_1m" --work /tmp/gc_cache_1m
  stress_jsons /tmp/gc_cache_1m "$work/cache_1m"
}
cache_full() {
  local q=(); [ "$quick" = 1 ] && q=(--quick)
  "$py" "$repo/tools/bench_cache.py" "${q[@]}" --out "$work/cache_full" --work /tmp/gc_cache_full
  stress_jsons /tmp/gc_cache_full "$work/cache_full"
}
classify() {
  local q=(--particles 1000000 --node-size 1000 --frames 48 --width 320 --height 180)
  [ "$quick" = 1 ] && q=(--quick)
  "$py" "$repo/tools/bench_classify.py" "${q[@]}" --variants subgroup,cells --out "$work/classify/1m" \
    --work /tmp/gc_classify_1m
  [ "$quick" = 1 ] && return
  "$py" "$repo/tools/bench_classify.py" --variants subgroup,cells --out "$work/classify/full" --work /tmp/gc_classify_full
}
big() {
  local q=(--particles 32M --width 1920 --height 1080 --budget 256MiB); [ "$quick" = 1 ] && q=(--quick)
  "$py" "$repo/tools/bench_mesh_path.py" "${q[@]}" --scenes porous --out "$work/big" --work /tmp/gc_big
}

export work repo mds py quick
export -f stress_jsons smoke tests tests_mesh mesh render render_mesh cache cache_1m cache_full classify big sweep
for s in $steps; do
  case $s in
    smoke) step smoke 90 smoke || { echo "smoke failed: no further steps (no driver found? GPU_CHECK_GL_DEBS)"; ldd "$mds" "$repo/build/libmdstream_vulkan.so" | grep -i "not found"; break; } ;;
    tests|tests_mesh) step "$s" 150 "$s" 140 ;;
    sweep) step sweep 300 sweep ;;
    classify) step classify 300 classify ;;
    *) step "$s" 200 "$s" ;;
  esac
done
echo "== done in $(( $(date +%s) - t0 )) s"
