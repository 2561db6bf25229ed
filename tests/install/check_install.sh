#!/bin/bash
# Installs the build tree into a scratch prefix and builds two of the example programs as a project
# of their own that finds the libraries with find_package(cosserat_mujoco), then runs them and the
# installed `cosserat` program on the installed models. Usage: check_install.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1 src=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
mkdir "$work/project"
cp "$src/examples/basic.cpp" "$src/examples/snapshot.cpp" "$work/project/"
cat > "$work/project/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.20)
project(uses_cosserat CXX)
set(CMAKE_CXX_STANDARD 20)
find_package(cosserat_mujoco 0.1 REQUIRED)
add_executable(basic basic.cpp)
target_link_libraries(basic PRIVATE cosserat::mujoco)
target_compile_definitions(basic PRIVATE COSSERAT_MODELS_DIR="${COSSERAT_MODELS_DIR}")
add_executable(snapshot snapshot.cpp)
target_link_libraries(snapshot PRIVATE cosserat::mujoco cosserat::render)
target_compile_definitions(snapshot PRIVATE COSSERAT_MODELS_DIR="${COSSERAT_MODELS_DIR}")
CMAKE
cmake -S "$work/project" -B "$work/project/build" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$work/prefix" > "$work/configure.log" || { cat "$work/configure.log"; exit 1; }
cmake --build "$work/project/build" -j2 > "$work/build.log" || { cat "$work/build.log"; exit 1; }
models=$work/prefix/share/cosserat_mujoco/models
cd "$work"
"$work/project/build/basic" "$models/cantilever.xml" 0.05
"$work/project/build/snapshot" "$models/cantilever.xml" 0.05 "$work/snap.png"
test -s "$work/snap.png"
"$work/prefix/bin/cosserat" check "$models/cantilever.xml"
echo "installed package: two programs built with find_package(cosserat_mujoco) and run"
