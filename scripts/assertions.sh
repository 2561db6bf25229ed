#!/bin/bash
# Builds the project with assertions on (Eigen's eigen_assert: bounds, sizes, and its check that
# the step allocates no heap memory; libstdc++'s _GLIBCXX_ASSERTIONS), which the release builds
# compile out (they define NDEBUG), in build-assert/, and runs the test suite there. Extra
# arguments go to ctest (e.g. -R Cli). About 17 minutes to build and 3 to test on 2 cores; not
# part of CI. (Outside probe CI, fifty-first session: no assertion fired in the suite or in 101
# command lines over the shipped models.)
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-assert -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g -D_GLIBCXX_ASSERTIONS" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -g" \
  -DCOSSERAT_BUILD_EXAMPLES=ON
cmake --build build-assert -j"$(nproc)"
ctest --test-dir build-assert -j"$(nproc)" --output-on-failure "$@"
