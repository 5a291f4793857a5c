#!/bin/bash
# The test suite and the converter under GCC's sanitizers (CMake option MDSTREAM_SANITIZE).
# Not part of CI (a sanitized build and run take 30-40 minutes on 2 cores); run it after changes
# to threads, memory layout or anything that parses input. docs/testing.md says what it found.
#
#   bash tools/sanitize.sh            # both passes below
#   bash tools/sanitize.sh asan       # AddressSanitizer + UndefinedBehaviorSanitizer
#   bash tools/sanitize.sh tsan       # ThreadSanitizer
#
# asan: builds build-asan (-fsanitize=address,undefined) and runs the whole CTest suite, then the
#   converter commands (synth, convert from LAMMPS text in memory and out of core, raw, extended
#   XYZ, both meshlet builders, info, export) with leak detection. The suite runs without leak
#   detection: Mesa's lavapipe and its LLVM JIT leave allocations at exit that LeakSanitizer
#   cannot attribute (the driver is unloaded by then); the Khronos validation layer in the
#   rendering suites reports Vulkan objects the renderer did not destroy. One test is left out:
#   ConvertRoundTrip.PeakMemory... compares the converter's peak RSS with its budget, and
#   ASan's shadow memory and quarantine are counted in RSS.
# tsan: builds build-tsan (-fsanitize=thread; the executables of the threaded suites only) and
#   runs those suites (the converter's pipeline, the streaming cache's readers, the streamed
#   renderer, the stress command) and the converter commands. tests/sanitizers/tsan.supp
#   silences races inside lavapipe itself (Mesa is not instrumented).
#
# Every report goes to a file (log_path); a pass fails when a test fails or any report was
# written, including reports of child processes whose exit status a test expected to be non-zero.
# BUILD_ROOT (default: the repository) holds build-asan/ and build-tsan/; JOBS (default 2).
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
root=${BUILD_ROOT:-$repo}
jobs=${JOBS:-2}
mode=${1:-all}
case "$mode" in all|asan|tsan) ;; *) echo "usage: bash tools/sanitize.sh [asan|tsan]" >&2; exit 2 ;; esac
status=0

# The converter's commands on inputs large enough for its threads: the text reader's parallel
# ranges (several 64 Ki-line blocks), the out-of-core spill (a budget below the input), the
# mapped raw path, the extended XYZ reader, both meshlet builders. $1: the mdstream to run.
converter_commands() {
  local mds=$1 work
  work=$(mktemp -d)
  "$mds" synth --scene ablation --particles 600000 -o "$work/a.dump" --quiet
  "$mds" convert "$work/a.dump" -o "$work/a.mds" --quiet
  "$mds" convert "$work/a.dump" -o "$work/a_ooc.mds" --memory-budget 16MiB --quiet
  "$mds" info "$work/a_ooc.mds" --verify > /dev/null  # out of core: nodes end at bin boundaries
  "$mds" convert "$work/a.dump" -o "$work/a_oct.mds" --meshlet-builder octree --quiet
  "$mds" info "$work/a.mds" --json > /dev/null
  "$mds" export "$work/a_oct.mds" -o "$work/a.xyz"
  "$mds" convert "$work/a.xyz" -o "$work/a_xyz.mds" --quiet
  /usr/bin/python3 - "$work/a.dump" "$work/a.f32" <<'EOF'
import sys
import numpy as np
with open(sys.argv[1], "rb") as f:  # id type x y z after 9 header lines
    for _ in range(9):
        f.readline()
    v = np.array(f.read().split(), dtype=np.float64).reshape(-1, 5)
v[:, 2:5].astype("<f4").tofile(sys.argv[2])
EOF
  "$mds" convert "$work/a.f32" --format raw -o "$work/a_raw.mds" --quiet
  rm -rf "$work"
}

# $1: the log folder of a pass; fails the pass when a report was written.
check_reports() {
  if compgen -G "$1/*" > /dev/null; then
    echo "sanitize.sh: reports in $1:" >&2
    grep -h 'SUMMARY' "$1"/* | sort | uniq -c >&2 || true
    status=1
  fi
}

if [ "$mode" != tsan ]; then
  b=$root/build-asan
  logs=$b/sanitizer-logs
  cmake -S "$repo" -B "$b" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMDSTREAM_SANITIZE=address,undefined > /dev/null
  cmake --build "$b" -j"$jobs"
  rm -rf "$logs" && mkdir -p "$logs"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:log_path=$logs/ubsan"
  ASAN_OPTIONS="detect_leaks=0:detect_stack_use_after_return=1:log_path=$logs/asan" \
    ctest --test-dir "$b" -j"$jobs" --output-on-failure -E 'ConvertRoundTrip\.PeakMemory' || status=1
  ASAN_OPTIONS="detect_leaks=1:detect_stack_use_after_return=1:log_path=$logs/asan" \
    LSAN_OPTIONS="suppressions=$repo/tests/fuzz/lsan.supp" converter_commands "$b/mdstream" || status=1
  check_reports "$logs"
  unset UBSAN_OPTIONS
fi

if [ "$mode" != asan ]; then
  b=$root/build-tsan
  logs=$b/sanitizer-logs
  cmake -S "$repo" -B "$b" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMDSTREAM_SANITIZE=thread > /dev/null
  suites=(test_streaming_io test_text_lines test_convert_raw test_convert_roundtrip test_convert_errors test_synth
          test_store test_streaming_render test_streaming_resize test_stress_cli test_render_host)
  cmake --build "$b" -j"$jobs" --target mdstream mdstream_vulkan_module mdstream_pcl_module mdstream_h5md_module "${suites[@]}"
  rm -rf "$logs" && mkdir -p "$logs"
  # Only the suites built above are registered (gtest_discover_tests runs after each build); the
  # others appear as one *_NOT_BUILT entry each, and MeshLavapipe.* re-runs whole executables.
  export TSAN_OPTIONS="halt_on_error=0:detect_deadlocks=0:log_path=$logs/tsan:suppressions=$repo/tests/sanitizers/tsan.supp"
  ctest --test-dir "$b" -j"$jobs" --output-on-failure -E '^MeshLavapipe\.|_NOT_BUILT' || status=1
  converter_commands "$b/mdstream" || status=1
  check_reports "$logs"
  unset TSAN_OPTIONS
fi

if [ $status -eq 0 ]; then echo "sanitize.sh: $mode clean"; else echo "sanitize.sh: $mode FAILED" >&2; fi
exit $status
