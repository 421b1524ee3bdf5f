#!/usr/bin/python3
"""The accuracy figures of README's Figures table as markdown rows, each with the baseline a
trivial answer gets measured in the same job (the neutral face, the generic head, the video's
own solve), their ratio and the target, from the outputs of the jobs:

  accuracy_rows.py [--demo out/demo] [--lipsync out/lipsync]
                   [--blendshapes out/bench_all/blendshapes.json]

A missing output is reported as a row that says so. Run with /usr/bin/python3 (only the
standard library is needed).
"""
import argparse
import json
import os
import sys


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        sys.stderr.write(f"accuracy_rows: {path}: {e}\n")
        return None


def row(figure, measured, baseline, target, source):
    """One markdown row: the figure, its baseline, their ratio (measured / baseline)."""
    if measured is None or baseline is None:
        return f"| {figure} | not found | | {target} | `{source}` |"
    ratio = measured / baseline if baseline else float("nan")
    return f"| {figure} | {measured:.4g} ({baseline:.4g}) | {ratio:.3f} | {target} | `{source}` |"


def missing(figure, path, source):
    return f"| {figure} | no {path} | | | `{source}` |"


def demo_rows(folder):
    source = "jobs/demo.toml"
    honest = load(os.path.join(folder, "metrics.json"))
    if honest is None:
        return [missing("demo", os.path.join(folder, "metrics.json"), source)]
    rows = []
    truerig = load(os.path.join(folder, "metrics_truerig.json")) or {}
    oracle = load(os.path.join(folder, "metrics_oracle.json")) or {}
    person = load(os.path.join(folder, "metrics_person.json")) or {}
    rows.append(row("demo: weight MAE over active true weights (neutral face)",
                    honest.get("active_weights_mae"), honest.get("active_weights_mae_neutral"),
                    "ratio <= 0.5", source))
    rows.append(row("demo: expression vertex error / IOD (neutral face)",
                    honest.get("expression_err_rel"), honest.get("expression_err_rel_neutral"),
                    "<= 0.02", source))
    rows.append(row("demo: landmark NME (true rig on the same translations)",
                    honest.get("landmark_nme"), truerig.get("landmark_nme"), "< 0.03", source))
    rows.append(row("demo: pose error, deg (true rig and true segmentation)",
                    honest.get("pose_err_deg_mean"), oracle.get("pose_err_deg_mean"), "< 2",
                    source))
    rows.append(row("demo: person fit vertex RMS / IOD (generic head)",
                    person.get("vertex_rms_over_iod"), person.get("template_vertex_rms_over_iod"),
                    "ratio <= 0.5 (over 8 people: analysis/person_fit_eval.sh)", source))
    return rows


def lipsync_rows(folder):
    source = "jobs/lipsync.toml"
    path = os.path.join(folder, "metrics.json")
    metrics = load(path)
    if metrics is None:
        return [missing("lip-sync", path, source)]
    by_name = {r["name"]: r for r in metrics.get("rows", [])}
    video = by_name.get("video solve", {})
    neutral = next((r for n, r in by_name.items() if n.startswith("neutral mouth")), {})
    blend = by_name.get("video + lip video blend", {})
    words = by_name.get("video + lip video (transcript) blend", {})
    return [
        row("lip-sync: mouth MAE, lip video blended (video solve)", blend.get("mouth_mae"),
            video.get("mouth_mae"), "ratio <= 0.75", source),
        row("lip-sync: mouth MAE, lip video blended (neutral mouth)", blend.get("mouth_mae"),
            neutral.get("mouth_mae"), "reported", source),
        row("lip-sync: lip closure F1, lip video blended (video solve)", blend.get("closure_f1"),
            video.get("closure_f1"), ">= 0.8", source),
        row("lip-sync: lip closure F1, lip video with its words blended (video solve)",
            words.get("closure_f1"), video.get("closure_f1"), ">= 0.8", source),
    ]


def blendshapes_rows(path):
    source = "jobs/blendshapes.toml"
    metrics = load(path)
    if metrics is None:
        return [missing("blendshapes", path, source)]
    return [
        row("blendshapes: held-out reconstruction, mm (template shapes)",
            metrics.get("ours_test"), metrics.get("template_test"), "ratio <= 0.85", source),
        row("blendshapes: held-out reconstruction, mm (example-based rigging)",
            metrics.get("ours_test"), metrics.get("example_based_test"), "ratio <= 1", source),
    ]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--demo", help="the demo job's output folder (out/demo)")
    parser.add_argument("--lipsync", help="the lip-sync job's output folder (out/lipsync)")
    parser.add_argument("--blendshapes", help="eval blendshapes --json's output")
    args = parser.parse_args()
    rows = []
    if args.demo:
        rows += demo_rows(args.demo)
    if args.lipsync:
        rows += lipsync_rows(args.lipsync)
    if args.blendshapes:
        rows += blendshapes_rows(args.blendshapes)
    print("| figure | measured (baseline) | ratio | target | job |")
    print("| --- | --- | --- | --- | --- |")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
