#!/usr/bin/python3
"""Collects the metrics JSON of many runs into one CSV and one markdown table.

Each run writes its metrics as one JSON object (e.g. `facecap eval track ... --json >
runs/a/metrics.json`). This script finds every `*.json` under the given directories (or takes
the files given), flattens nested objects into dotted column names, and writes:

  OUT.csv   one row per run, columns sorted, the run's path first
  OUT.md    the same as a markdown table

Usage: analysis/collect_metrics.py [--out sweep] DIR_OR_FILE [...]
Runs with Debian's /usr/bin/python3 (no third-party modules needed).
"""
import argparse
import csv
import json
import os
import sys


def flatten(obj, prefix=""):
    out = {}
    for key, value in obj.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, name + "."))
        elif isinstance(value, list):
            out[name] = " ".join(str(v) for v in value)
        else:
            out[name] = value
    return out


def find_json(paths):
    for path in paths:
        if os.path.isdir(path):
            for root, _, files in sorted(os.walk(path)):
                for f in sorted(files):
                    if f.endswith(".json"):
                        yield os.path.join(root, f)
        elif os.path.isfile(path):
            yield path
        else:
            print(f"collect_metrics: {path}: no such file or directory", file=sys.stderr)


def fmt(value):
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("paths", nargs="+", help="directories to search or JSON files")
    parser.add_argument("--out", default="metrics", help="output prefix (default: metrics)")
    args = parser.parse_args()

    rows = []
    for path in find_json(args.paths):
        try:
            with open(path) as f:
                data = json.load(f)
        except (OSError, json.JSONDecodeError) as e:
            print(f"collect_metrics: {path}: not a JSON object ({e}); skipped", file=sys.stderr)
            continue
        if not isinstance(data, dict):
            print(f"collect_metrics: {path}: not a JSON object; skipped", file=sys.stderr)
            continue
        row = {"run": os.path.relpath(path)}
        row.update(flatten(data))
        rows.append(row)
    if not rows:
        print("collect_metrics: no metrics found", file=sys.stderr)
        return 3
    columns = ["run"] + sorted({k for r in rows for k in r if k != "run"})
    with open(args.out + ".csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    with open(args.out + ".md", "w") as f:
        f.write("| " + " | ".join(columns) + " |\n")
        f.write("|" + "---|" * len(columns) + "\n")
        for r in rows:
            f.write("| " + " | ".join(fmt(r.get(c, "")) for c in columns) + " |\n")
    print(f"collect_metrics: {len(rows)} runs -> {args.out}.csv, {args.out}.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
