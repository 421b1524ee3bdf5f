#!/usr/bin/python3
"""Benchmark bars: each figure against its target, from a CSV with columns
name,value,target,unit (one benchmark per row; higher is better unless the unit starts with
"s" or "ms", where lower is better).

Usage: analysis/plot_benchmarks.py benchmarks.csv --out benchmarks.png
"""
import argparse
import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("csv")
    p.add_argument("--out", default="benchmarks.png")
    a = p.parse_args()
    rows = list(csv.DictReader(open(a.csv)))
    if not rows:
        raise SystemExit(f"plot_benchmarks: {a.csv} has no rows")
    names = [r["name"] for r in rows]
    ratios = []
    for r in rows:
        value, target = float(r["value"]), float(r["target"])
        lower_better = r["unit"].startswith(("s", "ms"))
        ratios.append(target / value if lower_better else value / target)
    fig, ax = plt.subplots(figsize=(8, 0.5 * len(rows) + 1.5))
    colors = ["tab:green" if x >= 1 else "tab:red" for x in ratios]
    ax.barh(names, ratios, color=colors)
    ax.axvline(1.0, color="black", linewidth=1)
    for i, r in enumerate(rows):
        ax.text(ratios[i], i, f"  {float(r['value']):.3g} {r['unit']} (target {r['target']})",
                va="center", fontsize=8)
    ax.set_xlabel("figure / target (> 1: target met)")
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)
    print(f"plot_benchmarks: {len(rows)} benchmarks -> {a.out}")


if __name__ == "__main__":
    main()
