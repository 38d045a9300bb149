#!/usr/bin/python3
"""Plots what cloth_bench's measuring modes write (cloth_bench runs it for --png; scripts/accuracy.py too).

    accuracy_plot.py pareto    RESULTS.csv OUT.png [--title TEXT]   cost against max error, Pareto front marked
    accuracy_plot.py stability MAP.csv     OUT.png                  largest stable step against omega, with theory

The CSVs start with "# key: value" lines (metadata), then a header row. Needs matplotlib (python3-matplotlib);
run it with /usr/bin/python3.
"""

import argparse
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the backend)

INTEGRATORS = ("forward_euler", "symplectic_euler", "midpoint", "rk4", "implicit_euler")
COLORS = {"forward_euler": "tab:red", "symplectic_euler": "tab:blue", "midpoint": "tab:orange", "rk4": "tab:green",
          "implicit_euler": "tab:purple"}
# An error of exactly 0 (a setting identical to the reference) cannot sit on a log axis: drawn at this floor.
ERROR_FLOOR_M = 1e-12
REALTIME_COST_MS_PER_S = 1000.0
DPI = 110


def read_csv(path):
    """(metadata dict of lists, rows as dicts)."""
    metadata = {}
    lines = []
    with open(path) as f:
        for line in f:
            if line.startswith("# "):
                key, _, value = line[2:].rstrip("\n").partition(": ")
                metadata.setdefault(key, []).append(value)
            elif line.strip():
                lines.append(line)
    return metadata, list(csv.DictReader(lines))


def meta(metadata, key, default=""):
    values = metadata.get(key)
    return values[0] if values else default


def plot_pareto(csv_path, png_path, title=None):
    metadata, rows = read_csv(csv_path)
    stable = [r for r in rows if r["stable"] == "1"]
    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    for name in INTEGRATORS:
        points = [r for r in stable if r["integrator"] == name]
        if not points:
            continue
        ax.scatter([float(r["cost_ms_per_s"]) for r in points],
                   [max(float(r["max_error_m"]), ERROR_FLOOR_M) for r in points],
                   color=COLORS[name], s=28, label=name, zorder=3)
        for r in points:
            ax.annotate(r["substeps"], (float(r["cost_ms_per_s"]), max(float(r["max_error_m"]), ERROR_FLOOR_M)),
                        textcoords="offset points", xytext=(4, 3), fontsize=7, color=COLORS[name])
    front = sorted((r for r in stable if r["pareto"] == "1"), key=lambda r: float(r["cost_ms_per_s"]))
    if front:
        xs = [float(r["cost_ms_per_s"]) for r in front]
        ys = [max(float(r["max_error_m"]), ERROR_FLOOR_M) for r in front]
        ax.step(xs, ys, where="post", color="black", linewidth=1, zorder=2)
        ax.scatter(xs, ys, s=120, facecolors="none", edgecolors="black", linewidths=1.2, zorder=4,
                   label="Pareto front (not dominated)")
    ax.axvline(REALTIME_COST_MS_PER_S, color="grey", linestyle="--", linewidth=1)
    ax.text(REALTIME_COST_MS_PER_S, 1.0, " real time", transform=ax.get_xaxis_transform(), va="top", fontsize=8,
            color="grey")
    max_error = meta(metadata, "max_error_m")
    if max_error:
        ax.axhline(float(max_error), color="grey", linestyle=":", linewidth=1)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost, ms of CPU per simulated second (this machine)")
    ax.set_ylabel("max position error over the span, m")
    unstable = len(rows) - len(stable)
    ax.set_title(title or "%s %s, %s s: cost against error (%d of %d settings diverged, not shown)" % (
        meta(metadata, "scene"), meta(metadata, "grid"), meta(metadata, "seconds"), unstable, len(rows)), fontsize=9)
    ax.grid(True, which="major", linewidth=0.4, alpha=0.5)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(png_path, dpi=DPI)
    plt.close(fig)


def plot_stability(csv_path, png_path):
    metadata, rows = read_csv(csv_path)
    names = [n for n in INTEGRATORS if any(r["integrator"] == n for r in rows)]
    fig, axes = plt.subplots(1, len(names), figsize=(4.0 * len(names), 4.2), sharey=True, squeeze=False)
    for ax, name in zip(axes[0], names):
        for damped, color in (("0", "tab:blue"), ("1", "tab:red")):
            label = "damped" if damped == "1" else "undamped"
            for sweep, marker in (("stiffness", "o"), ("mass", "s")):
                points = [r for r in rows if r["integrator"] == name and r["damped"] == damped
                          and r["sweep"] == sweep]
                points.sort(key=lambda r: float(r["omega_max_rad_per_s"]))
                omegas = [float(r["omega_max_rad_per_s"]) for r in points]
                measured = [float(r["h_measured_s"]) for r in points]
                # A theory capped at the largest step tried (implicit Euler) is no limit: not drawn.
                theory = [0.0 if r["theory_capped"] == "1" else float(r["h_theory_s"]) for r in points]
                shown = [(w, h) for w, h in zip(omegas, measured) if h > 0]
                ax.scatter([w for w, _ in shown], [h for _, h in shown], marker=marker, color=color, s=22,
                           facecolors=color if sweep == "stiffness" else "none", zorder=3,
                           label="measured, %s, %s sweep" % (label, sweep))
                theory_shown = [(w, h) for w, h in zip(omegas, theory) if h > 0]
                if theory_shown:
                    ax.plot([w for w, _ in theory_shown], [h for _, h in theory_shown], color=color,
                            linewidth=1, linestyle="-" if sweep == "stiffness" else "--",
                            label="theory, %s, %s sweep" % (label, sweep))
        if name == "symplectic_euler":
            ref = 2.0
        elif name == "rk4":
            ref = 2.83
        else:
            ref = None
        all_omegas = sorted(float(r["omega_max_rad_per_s"]) for r in rows)
        if ref and all_omegas:
            ax.plot(all_omegas, [ref / w for w in all_omegas], color="black", linewidth=0.6, linestyle=":",
                    label="h = %.2f / omega" % ref)
        if name in ("forward_euler", "midpoint"):
            ax.text(0.03, 0.03, "theory undamped: unstable at every h", transform=ax.transAxes, fontsize=7)
        if name == "implicit_euler":
            ax.text(0.03, 0.03, "stable up to the largest h tried\n(100 / omega)", transform=ax.transAxes,
                    fontsize=7)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("omega_max of the grid, rad/s")
        ax.grid(True, which="major", linewidth=0.4, alpha=0.5)
    axes[0][0].set_ylabel("largest stable step h, s")
    handles, labels = axes[0][1 if len(names) > 1 else 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=7)
    fig.suptitle("largest stable step, %s free cloth: measured (points) and single-mode theory (lines)"
                 % meta(metadata, "grid"), fontsize=10)
    fig.tight_layout(rect=(0, 0.12, 1, 0.95))
    fig.savefig(png_path, dpi=DPI)
    plt.close(fig)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("kind", choices=("pareto", "stability"))
    parser.add_argument("csv")
    parser.add_argument("png")
    parser.add_argument("--title")
    args = parser.parse_args(argv)
    if args.kind == "pareto":
        plot_pareto(args.csv, args.png, args.title)
    else:
        plot_stability(args.csv, args.png)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
