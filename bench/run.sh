#!/usr/bin/env bash
# Runs the benchmark suite (bench/README.md).
#
#   bash bench/run.sh            quick mode: every benchmark on a small grid, < 2 minutes on 2 cores
#                                (CI smoke run); results in build/bench-quick/
#   bash bench/run.sh --full     the README figures: full grids, medians of repeated runs, tens of
#                                minutes; results in docs/bench/ (JSON, PNG, RESULTS.md)
# Options: --out DIR (where results go), --build DIR (CMake build directory, default build),
#          --only NAME (elastica|work_precision|stress|stage_cost|kernels; repeatable).
# Builds what it needs: with the top-level add_subdirectory(bench) the `benchmarks` target of the
# build directory, otherwise the stand-alone project bench/standalone in BUILD/bench-standalone.
# Reference trajectories of the work-precision study are cached in docs/bench/reference_*.json
# (they take minutes to compute; delete them to recompute).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
mode=quick
out=""
build="$root/build"
only=()
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) mode=quick ;;
    --full) mode=full ;;
    --out) out="$2"; shift ;;
    --build) build="$2"; shift ;;
    --only) only+=("$2"); shift ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) echo "run.sh: unknown option $1" >&2; exit 1 ;;
  esac
  shift
done
[ -n "$out" ] || { [ "$mode" = full ] && out="$root/docs/bench" || out="$build/bench-quick"; }
mkdir -p "$out"
out="$(cd "$out" && pwd)"
wants() { [ ${#only[@]} -eq 0 ] && return 0; for o in "${only[@]}"; do [ "$o" = "$1" ] && return 0; done; return 1; }

# ---- build
if grep -Eq '^[[:space:]]*add_subdirectory\(bench\)' "$root/CMakeLists.txt"; then
  [ -f "$build/CMakeCache.txt" ] || cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$build" --target benchmarks -j2 >/dev/null
  bin="$build/bench"; elastica="$build/elastica_convergence"
else
  sb="$build/bench-standalone"
  [ -f "$sb/CMakeCache.txt" ] || cmake -S "$root/bench/standalone" -B "$sb" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$sb" --target benchmarks -j2 >/dev/null
  bin="$sb/bench"; elastica="$sb/elastica_convergence"
fi

q=""; [ "$mode" = quick ] && q="--quick"
start=$(date +%s)
stamp() { echo "[$(( $(date +%s) - start )) s] $*"; }
cd "$root"
if wants elastica; then
  stamp "elastica_convergence $q"
  "$elastica" $q | tee "$out/elastica_convergence.txt"
fi
if wants work_precision; then
  stamp "work_precision $q"
  if [ "$mode" = quick ]; then
    "$bin/bench_work_precision" --quick --reps 3 --out "$out"
  else
    "$bin/bench_work_precision" --reps 5 --out "$out"
  fi
fi
if wants stress; then
  stamp "stress $q"
  "$bin/bench_stress" $q --out "$out"
fi
if wants stage_cost; then
  stamp "stage_cost $q"
  "$bin/bench_stage_cost" $q --out "$out"
  # short clamped rods, default Gauss and Lobatto mass rules (the README's short-rod table)
  stamp "stage_cost $q (short rods)"
  "$bin/bench_stage_cost" $q --models "$root/docs/bench/repro/short_rods" --out "$out/short_rods"
fi
if wants kernels && [ -x "$bin/bench_kernels" ]; then
  stamp "kernels"
  if [ "$mode" = quick ]; then min=0.01; reps=1; else min=0.2; reps=5; fi
  "$bin/bench_kernels" --benchmark_min_time=$min --benchmark_repetitions=$reps \
    --benchmark_report_aggregates_only=$([ $reps -gt 1 ] && echo true || echo false) \
    --benchmark_out="$out/kernels.json" --benchmark_out_format=json
fi
stamp "report"
# the system's python3 has Debian's python3-matplotlib (a pyenv or venv python3 may not)
py=""
for p in /usr/bin/python3 python3; do
  if command -v "$p" >/dev/null && "$p" -c "import matplotlib" 2>/dev/null; then py="$p"; break; fi
done
[ -n "$py" ] || py="$(command -v python3 || true)"
if [ -n "$py" ]; then
  "$py" "$root/bench/report.py" "$out"
else
  echo "run.sh: no python3: JSON results only (tables and plots: bench/report.py)"
fi
stamp "done: results in $out"
