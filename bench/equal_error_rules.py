#!/usr/bin/env python3
"""The work-precision study's equal-error table under three interpolation rules, side by side.

    python3 bench/equal_error_rules.py [DIR] [PROBLEM ...]     (default: docs/bench, every problem)

The study's summary (bench_work_precision, bench/report.py) takes the Pareto front of all runs of
one side (credited errors) and interpolates log(time) against log(error) between neighbouring
front points ("front"). That rule is not monotone: a contender that adds a front point of slightly
less error at a higher time becomes the start of the segment and can raise the time read at an
error. Two monotone alternatives, printed next to it for every problem and both sides:

  hull   the lower envelope of all chords between front points (the lower convex hull in log-log,
         plus every point's own time at any coarser error). Adding a point never raises a time.
  curve  each discretisation (same space knob, integrator and options: a run's label without its
         step) is a curve over the step size, interpolated between its own points only (what a
         user gets by choosing a step in between); the least time over all curves. Adding a point
         never raises a time; no segment joins two discretisations.

The study's tables use "front" (bench/report.py); this script is for judging that choice.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import report  # noqa: E402

PROBLEMS = ["cantilever", "circle", "flagellate", "flagellate_rigid", "octopus"]
ERRORS = (1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 1e-6)


def hull_time(fr, e):
    """Least time at error e over every front point at or below e and every chord spanning e."""
    if not fr or e < fr[-1][1]:
        return None
    best = min(t for t, ee in fr if ee <= e)
    for i in range(len(fr)):
        for k in range(i + 1, len(fr)):
            if fr[k][1] <= e <= fr[i][1]:
                best = min(best, report.time_at_error([fr[i], fr[k]], e))  # the chord
    return best


def curve_time(points, e):
    """Least time at error e over the discretisations, each interpolated along its own steps."""
    curves = {}
    for p in points:
        if report.credited(p) is not None and report.credited(p) > 0:
            curves.setdefault(report.discretisation(p), []).append(p)
    times = [report.time_at_error(report.front(ps), e) for ps in curves.values()]
    times = [t for t in times if t is not None]
    return min(times) if times else None


def table(j):
    report.credit_errors(j)
    ours = [p for f in j["families"] if not f["native"] for p in f["points"]]
    nat = [p for f in j["families"] if f["native"] for p in f["points"]]
    fo, fn = report.front(ours), report.front(nat)
    rules = {
        "front": (lambda e: report.time_at_error(fo, e), lambda e: report.time_at_error(fn, e)),
        "hull": (lambda e: hull_time(fo, e), lambda e: hull_time(fn, e)),
        "curve": (lambda e: curve_time(ours, e), lambda e: curve_time(nat, e)),
    }
    out = ["| error | " + " | ".join(f"{r}: ours, native, ratio" for r in rules) + " |",
           "|---|" + "---|" * len(rules)]
    for e in ERRORS:
        cells, any_time = [], False
        for ours_t, nat_t in rules.values():
            to, tn = ours_t(e), nat_t(e)
            any_time |= to is not None or tn is not None
            ratio = "-" if to is None or tn is None else f"{tn / to:.1f}x"
            cells.append(f"{report.fmt_t(to)}, {report.fmt_t(tn)}, **{ratio}**")
        if any_time:
            out.append(f"| {e:.0e} | " + " | ".join(cells) + " |")
    return out


def main():
    args = sys.argv[1:]
    d = args.pop(0) if args and os.path.isdir(args[0]) else os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "docs", "bench")
    for name in args or PROBLEMS:
        path = os.path.join(d, f"work_precision_{name}.json")
        if not os.path.exists(path):
            print(f"{path}: no such file", file=sys.stderr)
            continue
        print(f"### {name}\n")
        print("\n".join(table(report.load(path))) + "\n")


if __name__ == "__main__":
    main()
