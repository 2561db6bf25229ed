#!/usr/bin/env bash
# Installs what the project needs from Debian bookworm's packages. Idempotent: packages already
# present are not reinstalled, and apt is not touched at all when nothing is missing.
set -euo pipefail
packages=(
  build-essential cmake ninja-build  # toolchain
  libeigen3-dev                      # the solver core (Eigen only)
  libgtest-dev googletest            # tests
  libmujoco-dev                      # MuJoCo 2.2.2 (the coupling)
  libqhull-dev                       # its CMake config names qhull's include dir
  libtinyxml2-dev                    # MJCF pre-processing
  nlohmann-json3-dev                 # JSON reports of the command-line tool
  libosmesa6-dev libpng-dev          # headless rendering (render/): OSMesa, PNG files
  ffmpeg                             # optional: render --video
  python3-matplotlib                 # plots in docs/ (scripts/plot_flagellate.py, bench/report.py)
  libbenchmark-dev                   # micro-benchmarks of the kernels (bench/kernels_main.cpp)
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
fi
echo "setup: dependencies present"
