#!/usr/bin/env python3
"""Plots the soft-against-rigid sweep of ./build/flagellate_sweep (README, "Swimming flagellates").

  ./build/flagellate_sweep --csv out/flagellate_sweep.csv
  python3 scripts/plot_flagellate.py out/flagellate_sweep.csv docs/flagellate_sweep.png

Needs python3-matplotlib (scripts/setup.sh installs it).
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else "out/flagellate_sweep.csv"
    dst = sys.argv[2] if len(sys.argv) > 2 else "docs/flagellate_sweep.png"
    rows = list(csv.DictReader(open(src)))
    models = []
    for r in rows:
        if r["model"] not in models:
            models.append(r["model"])
    labels = {"flagellate_rigid.xml": "rigid (ABS)", "flagellate.xml": "soft (Dragon Skin 30)"}
    fig, ax = plt.subplots(2, 2, figsize=(10, 7))
    panels = [
        ("speed_m_s", 1e3, "swimming speed [mm/s]"),
        ("per_turn_m", 1e3, "distance per motor turn [mm]"),
        ("motor_torque_n_m", 1e3, "motor torque [mN m]"),
        ("wobble_deg", 1.0, "head wobble (RMS tilt) [deg]"),
    ]
    for a, (key, scale, label) in zip(ax.flat, panels):
        for mname in models:
            pts = [(float(r["frequency_hz"]), scale * float(r[key])) for r in rows if r["model"] == mname]
            pts.sort()
            a.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=labels.get(mname, mname))
        a.set_xlabel("motor frequency [Hz]")
        a.set_ylabel(label)
        a.grid(True, alpha=0.3)
        if key in ("per_turn_m", "wobble_deg"):
            a.set_ylim(bottom=0)
    ax[0, 0].legend()
    fig.suptitle("Flagellate in silicone oil (mu = 5 Pa s): soft against rigid flagellum")
    fig.tight_layout()
    fig.savefig(dst, dpi=110)
    print("wrote", dst)


if __name__ == "__main__":
    main()
