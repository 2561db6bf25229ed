#!/usr/bin/env python3
"""Tables and plots of the benchmark JSON files (bench/README.md).

Usage: report.py DIR [--no-plots]
Reads DIR/work_precision_*.json, DIR/stress.json, DIR/stage_cost.json, DIR/kernels.json and
DIR/elastica_convergence.txt (whichever exist) and writes
  DIR/RESULTS.md                        the tables (Markdown), with the machine they came from;
  DIR/work_precision_<problem>.png      error against wall time, log-log, one curve per contender
                                        (the Pareto front of its grid, credited errors: see
                                        credit_errors; every run's own error as a faint dot);
  DIR/stage_cost.png                    per-step cost by stage for each shipped model.
Plots need matplotlib (Debian: python3-matplotlib); without it only RESULTS.md is written.

       report.py DIR --readme README.md        also rewrites the README's generated blocks
       report.py DIR --check-readme README.md  only checks them (exit 1 and a diff if they differ)
The README's benchmark tables sit between `<!-- report.py:NAME -->` and `<!-- report.py:end -->`
lines and are generated from DIR's JSON (readme_blocks below), so that they cannot drift from the
shipped data; a test (Bench.ReadmeTablesAreTheShippedJson) runs the check.
"""
import glob
import json
import os
import sys


def load(path):
    with open(path) as f:
        return json.load(f)


def machine_line(m):
    return (f"{m.get('cpu', '?')}, {m.get('hardware_threads', '?')} hardware threads, {m.get('compiler', '?')}, "
            f"MuJoCo {m.get('mujoco', '?')}, Eigen {m.get('eigen', '?')}, {m.get('build', '?')}; "
            f"load average at start {m.get('loadavg_at_start', '?').split(' ')[0]}; {m.get('date', '?')}")


def fmt_e(x):
    return "-" if x is None else f"{x:.2e}"


def passes_at(row, key):
    """'; passes at h = ...' for a failing stress run searched at smaller steps (bench_stress)."""
    if row.get("runs_below") is None:
        return ""
    h = row.get(key)
    return f"; passes at h = {h:g}" if h is not None else "; no smaller step passes"


def fmt_t(x):
    if x is None:
        return "-"
    if x < 1e-4:
        return f"{x * 1e6:.0f} us"
    return f"{x * 1e3:.1f} ms" if x < 1 else f"{x:.2f} s"


def discretisation(p):
    """A run's label without its step ("PCS 4 sec trapezoidal-lin h=0.02" -> "PCS 4 sec trapezoidal-lin")."""
    return p["label"].rsplit(" h=", 1)[0]


def credit_errors(j):
    """Each point's credited error: the largest of its own and those of the same discretisation
    (family, and the label without its step) at smaller steps that were run. A coarse step that beats its finer
    ones got lucky (time and space errors cancelling at one sampling of the trajectory); the front
    and the equal-error tables count only what a user can rely on. Sets p["credited"]: the bench's own
    "credited_error" when the JSON has it (it computes the same), else computed here for older files."""
    for f in j["families"]:
        for p in f["points"]:
            if "credited_error" in p:
                p["credited"] = p["credited_error"]
                continue
            e = p["error"]
            if e is None:
                p["credited"] = None
                continue
            finer = [q["error"] for q in f["points"] if q["error"] is not None and q["h"] < p["h"] and
                     discretisation(q) == discretisation(p)]
            p["credited"] = max([e] + finer)


def credited(p):
    return p.get("credited", p["error"])


def side_points(j, native):
    """Every run of our families (native False) or of the native chains' (native True)."""
    return [p for f in j["families"] if f["native"] == native for p in f["points"]]


def front_points(points):
    """The points on the Pareto front (wall time ascending, credited error descending) among those
    with a finite error."""
    pts = sorted((p for p in points if credited(p) is not None and credited(p) > 0),
                 key=lambda p: (p["wall_s"], credited(p)))
    out = []
    for p in pts:
        if not out or credited(p) < credited(out[-1]):
            out.append(p)
    return out


def front(points):
    """Pareto front as (wall time, credited error) pairs (front_points)."""
    return [(p["wall_s"], credited(p)) for p in front_points(points)]


def interpolation(errors, e):
    """Where error e falls on a front's descending errors: (i0, i1, a), the time there being
    log t = log t[i0] + a (log t[i1] - log t[i0]) (interp_time); None when the front never gets
    that low."""
    import math
    if not errors or e < errors[-1]:
        return None
    if e >= errors[0]:
        return 0, 0, 0.0
    for i, (e0, e1) in enumerate(zip(errors, errors[1:])):
        if e1 <= e <= e0:
            if e0 == e1:
                return i + 1, i + 1, 0.0
            return i, i + 1, (math.log(e) - math.log(e0)) / (math.log(e1) - math.log(e0))
    return None


def interp_time(t0, t1, a):
    """log-log interpolation between two front times (interpolation's weight a; t0 itself at a = 0)."""
    import math
    return t0 if a == 0.0 else math.exp(math.log(t0) + a * (math.log(t1) - math.log(t0)))


def time_at_error(fr, e):
    """Least wall time to reach error e on a Pareto front, interpolating log(time) against log(error)
    between its points (None when the front never gets that low)."""
    b = interpolation([x[1] for x in fr], e)
    return None if b is None else interp_time(fr[b[0]][0], fr[b[1]][0], b[2])


def equal_error_rows(j, timed=lambda p: p):
    """Ours against the native chain at equal error: the Pareto fronts of all our families and of all
    native families (credited errors), interpolated (log-log) at errors from the coarsest to the
    finest reached. `timed` maps each point to the point with the wall time to use (cold_ratios)."""
    credit_errors(j)
    ours = front([timed(p) for p in side_points(j, False)])
    nat = front([timed(p) for p in side_points(j, True)])
    # errors below the reference's own resolution (two fine solutions differ by that much) measure
    # nothing: left out (outside probe Q: the soft flagellate's rows down to 3e-5 were time errors
    # of runs at the reference's own discretisation)
    resolution = j.get("reference", {}).get("check_difference") or 0.0
    rows = []
    for e in (1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 1e-6):
        if e < resolution:
            continue
        to, tn = time_at_error(ours, e), time_at_error(nat, e)
        if to is None and tn is None:
            continue
        rows.append((e, to, tn, None if to is None or tn is None else tn / to))
    return rows, ours, nat


def round_ratios(j, errors):
    """The equal-error ratio in each interleaved round: {error: [native / ours in round r, ...]}. The
    fronts and the points each row interpolates between are the table's (median wall times); each
    round puts in those points' own timings from that round where the run timed them again in
    interleaved rounds ("interleaved": wall_runs_s in round order, ours and the native chain's
    alternately), their medians elsewhere. The spread says how far a row's ratio moved within one
    run, between timings taken side by side ({} where no point was re-timed)."""
    credit_errors(j)
    sides = [side_points(j, False), side_points(j, True)]
    inter = [p for ps in sides for p in ps if p.get("interleaved") and p.get("wall_runs_s")]
    if not inter:
        return {}
    rounds = min(len(p["wall_runs_s"]) for p in inter)
    fronts = [front_points(ps) for ps in sides]

    def wall(p, r):
        return p["wall_runs_s"][r] if p.get("interleaved") and len(p.get("wall_runs_s", [])) > r else p["wall_s"]

    out = {}
    for e in errors:
        b = [interpolation([credited(p) for p in fr], e) for fr in fronts]
        if None in b:
            continue
        out[e] = []
        for r in range(rounds):
            t = [interp_time(wall(fr[i0], r), wall(fr[i1], r), a) for fr, (i0, i1, a) in zip(fronts, b)]
            out[e].append(t[1] / t[0])
    return out


def cold_ratios(j, errors):
    """The equal-error ratio with every run timed as the first after its model's load: {error: native
    / ours}. Runs under 10 ms are timed warm since the forty-fourth session (run again from the reset
    state; bench/README.md), their first runs' walls kept in wall_cold_runs_s: here their medians
    stand in for wall_s, and the fronts are taken again ({} where no run was timed warm)."""
    import statistics
    if not any(p.get("wall_cold_runs_s") for ps in (side_points(j, False), side_points(j, True)) for p in ps):
        return {}

    def cold(p):
        q = dict(p)
        if p.get("wall_cold_runs_s"):
            q["wall_s"] = statistics.median(p["wall_cold_runs_s"])
        return q
    rows, _, _ = equal_error_rows(j, cold)
    return {e: sp for e, _, _, sp in rows if e in errors and sp is not None}


def fmt_range(rs):
    """'(lo-hi)' of per-round ratios, '' when fewer than two."""
    if len(rs) < 2:
        return ""
    lo, hi = min(rs), max(rs)
    return f" ({fmt_ratio(lo)[:-1]}-{fmt_ratio(hi)})"


def work_precision_section(files, plots, outdir):
    out = ["## Work-precision (run time against error)", ""]
    for path in files:
        j = load(path)
        name = j["problem"]
        out += [f"### {name}", "", j["description"] + ".", ""]
        if "error" in j:
            out += [f"Not run: {j['error']}", ""]
            continue
        ref = j.get("reference", {})
        if ref.get("kind") == "analytic":
            out.append("Reference: analytic.")
        else:
            out.append(f"Reference: {ref['setting']['label']} (our solver); a second fine solution, "
                       f"{ref['check_setting']['label']}, differs from it by {ref['check_difference']:.2e} "
                       f"(errors below that are not resolved).")
        out += ["", f"Machine: {machine_line(j['machine'])}. Simulated time {j['duration_s']} s per run; wall "
                    f"times of the Pareto points and of every run under 10 ms are medians of repeated runs, those of "
                    f"the fronts' points under 2 s of interleaved rounds (ours and the native chain's alternately).", ""]
        out += ["| contender | best error | at wall time | fastest run | its error |", "|---|---|---|---|---|"]
        for f in j["families"]:
            pts = [p for p in f["points"] if p["error"] is not None]
            if not pts:
                out.append(f"| {f['name']} | diverged or failed | | | |")
                continue
            best = min(pts, key=lambda p: (p["error"], p["wall_s"]))
            fast = min(pts, key=lambda p: p["wall_s"])
            out.append(f"| {f['name']} | {fmt_e(best['error'])} ({best['label']}) | {fmt_t(best['wall_s'])} | "
                       f"{fmt_t(fast['wall_s'])} ({fast['label']}) | {fmt_e(fast['error'])} |")
        s = j.get("summary", {})
        out += ["", f"Least error reached: ours {fmt_e(s.get('best_error_ours'))}, native chain "
                    f"{fmt_e(s.get('best_error_native'))} (runs up to the cap of 10 s, full mode).", ""]
        rows, _, _ = equal_error_rows(j)
        if rows:
            res = ref.get("check_difference")
            out += ["At equal error (Pareto fronts of all our contenders and of all native chains, interpolated "
                    "log-log between their points; each run credited with the largest error of its own and of "
                    "the same discretisation at smaller steps, so that a lucky coarse step does not set the "
                    "front; '-': not reached" + (f"; errors below the reference's resolution {res:.1e} left out"
                                                  if res else "") + "):", "",
                    "| error | ours | native chain | native / ours |", "|---|---|---|---|"]
            for e, to, tn, sp in rows:
                out.append(f"| {e:.0e} | {fmt_t(to)} | {fmt_t(tn)} | {'-' if sp is None else f'{sp:.1f}x'} |")
            out.append("")
        if plots:
            png = os.path.join(outdir, f"work_precision_{name}.png")
            plot_work_precision(j, png)
            out += [f"![work-precision {name}](work_precision_{name}.png)", ""]
    return out


def plot_work_precision(j, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 5.5))
    credit_errors(j)
    cmap = plt.get_cmap("tab20")
    colors = [cmap(i) for i in (0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 1, 3, 5, 7, 9, 11, 13, 15, 17, 19)]
    for i, f in enumerate(j["families"]):
        pts = [p for p in f["points"] if p["error"] is not None and p["error"] > 0]
        if not pts:
            continue
        c = colors[i % len(colors)]
        ax.scatter([p["wall_s"] for p in pts], [p["error"] for p in pts], s=8, color=c, alpha=0.3)
        fr = front(pts)  # the family's front of credited errors
        style = "--" if f["native"] else "-"
        ax.plot([t for t, _ in fr], [e for _, e in fr], style, marker="o", ms=4, color=c, label=f["name"])
    ax.set_xscale("log")
    ax.set_yscale("log")
    ref = j.get("reference", {})
    if ref.get("check_difference"):
        ax.axhline(ref["check_difference"], color="gray", lw=0.8, ls=":")
        ax.text(ax.get_xlim()[0], ref["check_difference"], " resolution of the reference", color="gray",
                va="bottom", fontsize=7)
    ax.set_xlabel("wall time of the run [s]")
    ax.set_ylabel("relative error")
    m = j["machine"]
    ax.set_title(f"{j['problem']}: error against run time ({j['duration_s']} s simulated)\n"
                 f"{m.get('cpu', '?')}, {m.get('date', '?')[:10]}", fontsize=9)
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def corrections(row):
    """Newton corrections per step (and split steps) of a stress run, '-' without corrections."""
    c = row.get("newton_corrections_per_step")
    if c is None:
        return "-"
    splits = row.get("newton_splits", 0)
    return f"{c:.2f}" + (f" ({splits} split)" if splits else "")


def substeps_note(row):
    """' (N corr./step)' when the run at the largest stable step needed more than 10 Newton
    corrections per step: its iteration kept failing and splitting the steps (hidden sub-steps)."""
    h = row.get("largest_stable_step")
    for t in row.get("runs", []):
        if h is not None and t.get("h") == h and t.get("newton_corrections_per_step", 0) > 10:
            return f" ({t['newton_corrections_per_step']:.0f} corr./step)"
    return ""


def stress_section(path):
    j = load(path)
    out = ["## Stability stress tests", "", f"Machine: {machine_line(j['machine'])}.", ""]
    if j.get("parts_note"):
        out += [j["parts_note"], ""]
    out += ["Largest stable step (energy does not grow, state finite) of each integrator, and whether the "
            "resting state (static equilibrium) then stays put (tip drift < 1e-6 L); '(N corr./step)': the "
            "Newton iteration at that step needed more than 10 corrections per step, its failures splitting "
            "the steps (sub-stepping that the step alone does not show):", ""]
    mat = j.get("material", [])
    # the integrators in the order the bench ran them
    methods = []
    for r in mat + j.get("tipmass", []):
        if r["method"] not in methods:
            methods.append(r["method"])
    out += ["| Young's modulus [Pa] | L/r | " + " | ".join(methods) + " |", "|---|---|" + "---|" * len(methods)]
    cases = {}
    for r in mat:
        cases.setdefault((r["young"], r["slenderness"]), {})[r["method"]] = r
    for (E, sl), by in sorted(cases.items()):
        cells = []
        for m in methods:
            r = by.get(m)
            if not r:
                cells.append("-")
                continue
            h = r.get("largest_stable_step")
            rest = r.get("rest", {})
            cell = "none" if h is None else f"{h:g}" + substeps_note(r)
            if h is not None and rest and not rest.get("pass"):
                cell += " (rest: FAIL)"
            cells.append(cell)
        out.append(f"| {E:.0e} | {sl:g} | " + " | ".join(cells) + " |")
    out.append("")
    if j.get("turns"):
        out += ["Sections bent through several turns and nearly straight (no gravity, undamped):", "",
                "| theta = abs(k) L | integrator | h | result | energy growth |", "|---|---|---|---|---|"]
        for r in j["turns"]:
            out.append(f"| {r['theta']:.3g} | {r['method']} | {r['h']:g} | {'pass' if r['pass'] else 'FAIL: ' + r.get('reason', '')} "
                       f"| {r.get('energy_growth', 0):.1e} |")
        out.append("")
    if j.get("long"):
        out += ["Long runs (one that fails: the largest smaller step at which the same number of steps passes):", "", "| integrator | h | steps | result | energy growth | Newton corr./step | wall |", "|---|---|---|---|---|---|---|"]
        for r in j["long"]:
            out.append(f"| {r['method']} | {r['h']:g} | {r['steps']} | {'pass' if r['pass'] else 'FAIL: ' + r.get('reason', '') + passes_at(r, 'largest_passing_step')} "
                       f"| {r.get('energy_growth', 0):.1e} | {corrections(r)} | {fmt_t(r['wall_s'])} |")
        out.append("")
    if j.get("soft_string"):
        out += ["A string too soft for its own weight (docs/bench/repro/soft_string_collapse.xml, E = 1e3 Pa, "
                "L/r = 1000, stretching 6-8x), every integrator at 2 ms for 3 s (explicit ones that fail there: their "
                "largest stable step below it; implicit ones that fail: the largest smaller step at which they pass):", "",
                "| integrator | h | result | energy growth | Newton corr./step | wall |", "|---|---|---|---|---|---|"]
        for r in j["soft_string"]:
            res = 'pass' if r['pass'] else 'FAIL: ' + r.get('reason', '') + passes_at(r, 'largest_stable_step')
            if r.get("runs_below") is not None and r["method"] in ("euler", "rk4"):
                hs = r.get("largest_stable_step")
                res = f"unstable at 2 ms; largest stable step {hs if hs is not None else 'none'}"
            out.append(f"| {r['method']} | {r['h']:g} | {res} | {r.get('energy_growth', 0):.1e} | {corrections(r)} "
                       f"| {fmt_t(r['wall_s'])} |")
        out.append("")
    if j.get("tipmass"):
        out += ["Heavy tip masses (largest stable step):", "", "| tip mass / rod mass | " + " | ".join(methods) + " |",
                "|---|" + "---|" * len(methods)]
        by = {}
        for r in j["tipmass"]:
            by.setdefault(r["tip_mass_ratio"], {})[r["method"]] = r
        for ratio, d in sorted(by.items()):
            out.append(f"| {ratio:g} | " + " | ".join(
                "none" if d.get(m, {}).get("largest_stable_step") is None
                else f"{d[m]['largest_stable_step']:g}" + substeps_note(d[m]) for m in methods) + " |")
        out.append("")
    if j.get("contact"):
        out += ["Hard contact:", ""]
        for r in j["contact"]:
            if "largest_stable_step_with_contact" in r:
                out.append(f"- {r['case']}, {r['method']}: largest stable step {r['largest_stable_step_with_contact']} "
                           f"with contact, {r['largest_stable_step_without_contact']} without: "
                           f"{'pass' if r['pass'] else 'FAIL'}")
            else:
                out.append(f"- {r['case']}, {r['method']}: {'pass' if r['pass'] else 'FAIL: ' + r.get('reason', '')}"
                           + (f" (drift {r['drift_over_L']:.1e} L)" if 'drift_over_L' in r else ""))
        out.append("")
    out += [f"Failing cases: {j.get('failures', 0)}", ""]
    for f in j.get("failure_list", []):
        out.append(f"- {f}")
    out.append("")
    return out


def stage_section(path, plots, outdir):
    j = load(path)
    out = ["## Per-step cost by stage, features switched off, coupling overhead", "",
           f"Machine: {machine_line(j['machine'])}.", ""]
    cats = None
    for m in j["models"]:
        b = m["breakdown"]
        if cats is None:
            cats = list(b["categories_us"].keys())
    if not j["models"]:
        return out
    out += ["Per-step cost [us] by stage (from the same state; see bench/README.md for how each is measured):", ""]
    out += ["| stage | " + " | ".join(m["model"] for m in j["models"]) + " |",
            "|---|" + "---|" * len(j["models"])]
    out.append("| **step** | " + " | ".join(f"**{m['breakdown']['step_us']:.1f}**" for m in j["models"]) + " |")
    for c in cats:
        out.append(f"| {c} | " + " | ".join(f"{m['breakdown']['categories_us'].get(c, 0):.1f}" for m in j["models"]) + " |")
    out.append("| nv / sections / rod capsules / ncon | " + " | ".join(
        f"{m['nv']} / {m['sections']} / {m['rod_capsules']} / {m['ncon']}" for m in j["models"]) + " |")
    out.append("| heap allocations per step | " + " | ".join(str(m["allocations_per_step"]) for m in j["models"]) + " |")
    out.append("")
    out += ["Step time with a feature switched off (change against the shipped scene, same state; best of "
            "interleaved rounds):", ""]
    names = []
    for m in j["models"]:
        for v in m["features_off"]:
            if v["variant"] not in names:
                names.append(v["variant"])
    out += ["| variant | " + " | ".join(m["model"] for m in j["models"]) + " |", "|---|" + "---|" * len(j["models"])]
    for n in names:
        cells = []
        for m in j["models"]:
            v = next((v for v in m["features_off"] if v["variant"] == n), None)
            # the change against the shipped row's own best round (the first row), whatever the JSON's
            # 'change' holds: runs before the forty-sixth session divided by the shipped row's median
            base = m["features_off"][0]["step_us"]
            cells.append("n/a" if v is None else f"{v['step_us']:.1f} ({100 * (v['step_us'] / base - 1):+.0f}%)")
        out.append(f"| {n} | " + " | ".join(cells) + " |")
    out.append("")
    out += ["Coupling overhead: our step against MuJoCo's mj_step on (a) the same compiled model (proxies as rigid "
            "bodies: same dofs and geoms) and (b) the native chain with one body per section (same dofs). "
            "Goal: at most 2x.", "",
            "| model | ours (default integrator) | ours (euler) | mj_step, same model | ratio | native chain nv / ncon | mj_step, native | ratio (euler) |",
            "|---|---|---|---|---|---|---|---|"]
    for m in j["models"]:
        o = m["coupling_overhead"]
        out.append(f"| {m['model']} | {o['ours_step_us']:.1f} us | {o['ours_euler_step_us']:.1f} us | "
                   f"{o['same_model_mj_step_us']:.1f} us | {o['ratio_same_model']:.1f}x | "
                   f"{o.get('native_chain_nv', '-')} / {o.get('native_chain_ncon', '-')} | "
                   f"{o.get('native_chain_mj_step_us', float('nan')):.1f} us | "
                   f"{o.get('ratio_native_chain', float('nan')):.1f}x ({o.get('ratio_native_chain_euler', float('nan')):.1f}x) |")
    out.append("")
    if plots:
        plot_stages(j, os.path.join(outdir, "stage_cost.png"))
        out += ["![per-step cost by stage](stage_cost.png)", ""]
    return out


def plot_stages(j, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    models = j["models"]
    cats = list(models[0]["breakdown"]["categories_us"].keys())
    fig, ax = plt.subplots(figsize=(8, 4.5))
    bottom = [0.0] * len(models)
    for c in cats:
        vals = [m["breakdown"]["categories_us"].get(c, 0.0) for m in models]
        ax.bar([m["model"] for m in models], vals, bottom=bottom, label=c)
        bottom = [b + v for b, v in zip(bottom, vals)]
    ax.set_ylabel("microseconds per step")
    ax.set_yscale("log")
    ax.set_ylim(bottom=1)
    ax.set_title(f"per-step cost by stage\n{j['machine'].get('cpu', '?')}, {j['machine'].get('date', '?')[:10]}", fontsize=9)
    ax.legend(fontsize=6, loc="upper left")
    plt.xticks(fontsize=7, rotation=15)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def kernels_section(path):
    j = load(path)
    out = ["## Micro-benchmarks of the kernels (Google Benchmark)", "",
           f"Machine: {j['context'].get('host_name', '?')}, {j['context'].get('num_cpus', '?')} CPUs at "
           f"{j['context'].get('mhz_per_cpu', '?')} MHz, load average {j['context'].get('load_avg', '?')}; "
           f"{j['context'].get('date', '?')}.", "", "| kernel | CPU time | wall time |", "|---|---|---|"]
    for b in j["benchmarks"]:
        if b.get("run_type") == "aggregate" and b.get("aggregate_name") != "median":
            continue
        unit = b.get("time_unit", "ns")
        out.append(f"| {b['name']} | {b['cpu_time']:.0f} {unit} | {b['real_time']:.0f} {unit} |")
    out.append("")
    return out


# ---- the README's generated blocks ----------------------------------------------------------------

# the README's label for each work-precision problem (its error measure and simulated time)
PROBLEM_LABELS = {
    "cantilever": "cantilever released under gravity (RMS tip and mid-point / L, 2 s)",
    "cantilever_planar": "the same cantilever, planar on both sides: one bending dof per section, one hinge per "
                         "link (RMS tip and mid-point / L, 2 s)",
    "circle": "rod rolled into a circle (max point error / L)",
    "circle_planar": "the same circle, planar on both sides (max point error / L)",
    "flagellate_rigid": "rigid flagellate (mean swimming speed, 4 s)",
    "flagellate": "soft flagellate (mean swimming speed, 4 s)",
    "octopus": "octopus arm curling under cable tension (RMS tip and mid-site / L, 0.2 s)",
}
# the goal's problems: at equal error at least 10x faster than the best native chain
GOAL_PROBLEMS = ("cantilever", "cantilever_planar", "circle", "circle_planar", "flagellate_rigid", "flagellate")


def fmt_us(x):
    """A wall time for the README: 2-3 significant figures in us, ms or s."""
    if x is None:
        return "-"
    if x < 1e-3:
        return f"{x * 1e6:.0f} µs"
    if x < 1e-2:
        return f"{x * 1e3:.1f} ms"
    if x < 1:
        return f"{x * 1e3:.0f} ms"
    return f"{x:.2f} s"


def fmt_ratio(r):
    """Two significant figures, three just under 10 (9.97×, not a 10.0× that missed 10×)."""
    if r is None:
        return "-"
    return f"{r:.2f}×" if 9.95 <= r < 10 else f"{r:.1f}×" if r < 10 else f"{r:.0f}×"


def short_machine(m):
    return f"{m.get('cpu', '?')}, {m.get('date', '?')[:10]}"


def wp_files(outdir):
    order = list(PROBLEM_LABELS)
    js = [load(p) for p in glob.glob(os.path.join(outdir, "work_precision_*.json"))]
    js = [j for j in js if "error" not in j]
    return sorted(js, key=lambda j: order.index(j["problem"]) if j["problem"] in order else len(order))


def reaching(points, e):
    """The label of the cheapest run whose credited error is at most e (the front point that
    reaches e; the table's time interpolates between it and the one before), or '-'."""
    ok = [p for p in points if credited(p) is not None and 0 < credited(p) <= e]
    return min(ok, key=lambda p: p["wall_s"])["label"] if ok else "-"


def block_work_precision(outdir):
    out = ["| problem (error measure) | error | ours | native chain | native / ours (per round) | our run reaching it | native run reaching it |",
           "|---|---|---|---|---|---|---|"]
    js = wp_files(outdir)
    for j in js:
        rows, _, _ = equal_error_rows(j)
        spread = round_ratios(j, [e for e, _, _, _ in rows])
        ours, nat = side_points(j, False), side_points(j, True)
        label = PROBLEM_LABELS.get(j["problem"], j["problem"])
        res = j.get("reference", {}).get("check_difference")
        if res and res > 1e-6:
            label = label[:-1] + f"; the reference resolves {res:.1e})"
        for k, (e, to, tn, sp) in enumerate(rows):
            out.append(f"| {label if k == 0 else ''} | {e:.0e} | {fmt_us(to)} | {fmt_us(tn)} | "
                       f"{fmt_ratio(sp)}{fmt_range(spread.get(e, [])) if sp is not None else ''} | "
                       f"{reaching(ours, e)} | {reaching(nat, e) if tn is not None else '-'} |")
    out += ["", "Least error of any single run (ours / native chain; not credited, and ours below the reference's "
                "resolution where it has one): " + "; ".join(
        f"{j['problem']} {fmt_e(j['summary'].get('best_error_ours'))} / {fmt_e(j['summary'].get('best_error_native'))}"
        for j in js) + ".", "",
        "Runs: " + "; ".join(f"{j['problem']} {short_machine(j['machine'])}" for j in js) +
        " (`machine` in each `docs/bench/work_precision_*.json`)."]
    return out


def block_goal(outdir):
    """Where the 10x goal is met and where it is missed, problem by problem."""
    out = []
    for j in wp_files(outdir):
        if j["problem"] not in GOAL_PROBLEMS:
            continue
        rows, _, _ = equal_error_rows(j)  # (credits the errors: credited() below reads them)
        spread = round_ratios(j, [e for e, _, _, _ in rows])
        cold = cold_ratios(j, [e for e, _, _, _ in rows])

        def straddles(e):  # some round on either side of 10x: the machine does not resolve the row
            rs = spread.get(e, [])
            return bool(rs) and min(rs) < 10 <= max(rs)

        def entry(e, sp):  # the per-round range where it straddles 10x, and the ratio timed cold
            rs = spread.get(e, [])  # where that falls on the other side
            c = cold.get(e)
            flips = c is not None and (c < 10) != (sp < 10)
            return (f"{e:.0e} ({fmt_ratio(sp)}{'; rounds ' + fmt_range(rs)[2:-1] if straddles(e) else ''}"
                    f"{'; timed cold ' + fmt_ratio(c) if flips else ''})")
        # (outside probe BH: a row whose rounds straddle 10x had been counted met, and a rerun read 7.2x)
        met = [entry(e, sp) for e, to, tn, sp in rows if sp is not None and sp >= 10 and not straddles(e)]
        unresolved = [entry(e, sp) for e, to, tn, sp in rows if sp is not None and straddles(e)]
        missed = [entry(e, sp) for e, to, tn, sp in rows if sp is not None and sp < 10 and not straddles(e)]
        never = [e for e, to, tn, sp in rows if to is not None and tn is None]
        # the native side's least credited error (what the rows use: a run is credited with the
        # largest error of its own and of its finer steps)
        nat = [credited(p) for p in side_points(j, True)]
        nat_least = min((e for e in nat if e is not None and e > 0), default=None)
        parts = []
        if met:
            parts.append("met at " + ", ".join(met))
        if never:
            parts.append(f"{'from' if met else 'met from'} {max(never):.0e} down{'' if met else ', where'} only ours gets "
                         f"there (the native chain's least credited error {fmt_e(nat_least)})")
        if missed:
            parts.append("missed at " + ", ".join(missed))
        if unresolved:
            parts.append("not resolved (rounds on both sides of 10x) at " + ", ".join(unresolved))
        out.append(f"- {PROBLEM_LABELS.get(j['problem'], j['problem']).split(' (')[0]}: " + "; ".join(parts) + ".")
    return out


def block_coupling(outdir, path="stage_cost.json"):
    j = load(os.path.join(outdir, path))
    out = ["| model (nv, ncon) | ours | mj_step, same model | ratio | native chain nv / ncon | h | mj_step, native | ratio (ours with euler) |",
           "|---|---|---|---|---|---|---|---|"]
    for m in j["models"]:
        o = m["coupling_overhead"]
        h = o.get("native_chain_timestep")
        out.append(f"| {m['model']} (nv {m['nv']}, ncon {m['ncon']}) | {o['ours_step_us']:.3g} µs | "
                   f"{o['same_model_mj_step_us']:.3g} µs (ncon {o.get('same_model_ncon', '?')}) | {o['ratio_same_model']:.2f}× | "
                   f"{o.get('native_chain_nv', '-')} / {o.get('native_chain_ncon', '-')} | "
                   f"{'-' if h is None else f'{h * 1e3:g} ms'} | {o.get('native_chain_mj_step_us', float('nan')):.3g} µs | "
                   f"{o.get('ratio_native_chain', float('nan')):.2f}× ({o.get('ratio_native_chain_euler', float('nan')):.2f}×) |")
    rn = [m["coupling_overhead"].get("ratio_native_chain") for m in j["models"]]
    rs = [m["coupling_overhead"]["ratio_same_model"] for m in j["models"]]
    rn = [r for r in rn if r is not None]
    out += ["", f"Against the native chain {min(rn):.2f}-{max(rn):.2f}×, against the same compiled model "
                f"{min(rs):.2f}-{max(rs):.2f}×; {j['models'][0]['coupling_overhead']['rounds']} interleaved rounds, "
                f"medians; {short_machine(j['machine'])} (`docs/bench/{path}`)."]
    return out


def block_stress(outdir):
    j = load(os.path.join(outdir, "stress.json"))
    n = sum(len(j.get(k, [])) for k in ("material", "tipmass", "contact", "turns", "long", "soft_string"))
    out = [f"{n} cases ({len(j.get('material', []))} material and slenderness × integrator, "
           f"{len(j.get('tipmass', []))} tip masses, {len(j.get('contact', []))} contact, {len(j.get('turns', []))} "
           f"bent or straight sections, {len(j.get('long', []))} long runs, {len(j.get('soft_string', []))} soft string); "
           f"{j.get('failures', 0)} fail ({short_machine(j['machine'])}, `docs/bench/stress.json`):", ""]
    out += [f"- {f}" for f in j.get("failure_list", [])]
    return out


README_BLOCKS = {
    "work-precision": block_work_precision,
    "goal": block_goal,
    "coupling": block_coupling,
    # bench_stage_cost --models docs/bench/repro/short_rods --out docs/bench/short_rods
    "coupling-short-rods": lambda outdir: block_coupling(outdir, "short_rods/stage_cost.json"),
    "stress-failures": block_stress,
}


def readme_blocks(readme_text, outdir):
    """The README's text with every generated block rewritten from outdir's JSON."""
    lines = readme_text.split("\n")
    out, k = [], 0
    while k < len(lines):
        line = lines[k]
        out.append(line)
        k += 1
        if line.startswith("<!-- report.py:") and line.rstrip().endswith("-->") and "report.py:end" not in line:
            name = line.strip()[len("<!-- report.py:"):-len("-->")].strip()
            if name not in README_BLOCKS:
                raise SystemExit(f"report.py: unknown README block '{name}' (known: {', '.join(README_BLOCKS)})")
            end = k
            while end < len(lines) and not lines[end].startswith("<!-- report.py:end"):
                end += 1
            if end == len(lines):
                raise SystemExit(f"report.py: README block '{name}' has no '<!-- report.py:end -->' line")
            out += README_BLOCKS[name](outdir)
            out.append(lines[end])
            k = end + 1
    return "\n".join(out)


def main():
    if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        return 0 if len(sys.argv) >= 2 else 1
    outdir = sys.argv[1]
    for flag in ("--readme", "--check-readme"):
        if flag in sys.argv:
            k = sys.argv.index(flag)
            if k + 1 >= len(sys.argv):
                print(f"report.py: {flag} needs the README's path")
                return 2
            path = sys.argv[k + 1]
            text = open(path).read()
            new = readme_blocks(text, outdir)
            if flag == "--check-readme":
                if new == text:
                    print(f"{path}: the generated blocks are those of {outdir}'s JSON")
                    return 0
                import difflib
                sys.stdout.writelines(difflib.unified_diff(text.splitlines(True), new.splitlines(True), path,
                                                           "generated from " + outdir))
                print(f"\n{path}: generated blocks differ from {outdir}'s JSON: rerun "
                      f"`python3 bench/report.py {outdir} --readme {path}`")
                return 1
            with open(path, "w") as f:
                f.write(new)
            print(f"rewrote the generated blocks of {path}")
    if "--check-readme" in sys.argv:
        return 0
    plots = "--no-plots" not in sys.argv
    if plots:
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            print("report.py: matplotlib not found (python3-matplotlib): tables only")
            plots = False
    lines = ["# Benchmark results", "",
             "Generated by `bench/report.py` from the JSON files next to this file; produced by `bench/run.sh` "
             "(see bench/README.md for what each benchmark does and how to rerun it).", ""]
    wp = sorted(glob.glob(os.path.join(outdir, "work_precision_*.json")))
    if wp:
        lines += work_precision_section(wp, plots, outdir)
    if os.path.exists(os.path.join(outdir, "stress.json")):
        lines += stress_section(os.path.join(outdir, "stress.json"))
    if os.path.exists(os.path.join(outdir, "stage_cost.json")):
        lines += stage_section(os.path.join(outdir, "stage_cost.json"), plots, outdir)
    if os.path.exists(os.path.join(outdir, "kernels.json")):
        lines += kernels_section(os.path.join(outdir, "kernels.json"))
    el = os.path.join(outdir, "elastica_convergence.txt")
    if os.path.exists(el):
        lines += ["## Static cantilever against the elastica (`elastica_convergence`)", "", "```"]
        lines += open(el).read().rstrip().splitlines()
        lines += ["```", ""]
    with open(os.path.join(outdir, "RESULTS.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {os.path.join(outdir, 'RESULTS.md')}" + (" and plots" if plots else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
