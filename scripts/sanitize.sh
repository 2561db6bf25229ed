#!/bin/bash
# Builds the project with AddressSanitizer and UndefinedBehaviorSanitizer (COSSERAT_SANITIZE, in
# build-asan/) and runs the test suite there: any heap or stack error, leak or undefined behaviour
# fails the test that met it. Extra arguments go to ctest (e.g. -R Cli). About 15 minutes to build
# and 20 to test on 2 cores; not part of CI.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCOSSERAT_SANITIZE=ON -DCOSSERAT_BUILD_EXAMPLES=ON
cmake --build build-asan -j"$(nproc)"
# libOSMesa keeps 480 bytes per context it creates (not per frame or step), which LeakSanitizer
# would report at the exit of every program that renders
echo "leak:libOSMesa" > build-asan/lsan.supp
export ASAN_OPTIONS=detect_leaks=1
export LSAN_OPTIONS="suppressions=$PWD/build-asan/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS=print_stacktrace=1
ctest --test-dir build-asan -j"$(nproc)" --output-on-failure "$@"
