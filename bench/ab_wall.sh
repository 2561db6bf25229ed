#!/bin/bash
# Wall time of `cosserat run` for two builds, alternated so that both see the same machine load.
# usage: bench/ab_wall.sh COSSERAT_A COSSERAT_B MODEL.xml [DURATION [ROUNDS [run options...]]]
# Prints the fastest of ROUNDS runs (default 5) of each and their ratio B/A.
set -eu
if [ $# -lt 3 ]; then
  sed -n 2,4p "$0" | sed 's/^# //'
  exit 2
fi
A=$1 B=$2 M=$3 D=${4:-1} R=${5:-5}
shift $(( $# < 5 ? $# : 5 ))
# the first line of `run`'s output: "simulated ... in W s wall; ..."
wall() {
  local bin=$1 out
  shift
  if ! out=$("$bin" run "$M" --duration "$D" "$@" 2>&1); then
    echo "ab_wall: '$bin run $M' failed: $(echo "$out" | grep -m1 -i 'diverged\|error' || echo "$out" | tail -1)" >&2
    return 1
  fi
  echo "$out" | sed -nE '1s/.* in ([0-9.]+) s wall.*/\1/p'
}
best_a="" best_b=""
for _ in $(seq "$R"); do
  ta=$(wall "$A" "$@"); tb=$(wall "$B" "$@")
  [ -n "$ta" ] && [ -n "$tb" ] || { echo "ab_wall: a run failed (no wall time printed)" >&2; exit 1; }
  best_a=$(python3 -c "print(min(x for x in [$ta, ${best_a:-$ta}]))")
  best_b=$(python3 -c "print(min(x for x in [$tb, ${best_b:-$tb}]))")
done
echo "$M: A $best_a s, B $best_b s, B/A $(python3 -c "print(round($best_b / $best_a, 3))")"
