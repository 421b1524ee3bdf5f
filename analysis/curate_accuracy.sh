#!/usr/bin/env bash
# How accurate is the curation of paper 000 Sec. 3 on footage whose truth is known? Makes a
# wild clip of one person with its mp4 (`facecap synth clip --video`), ingests the mp4 like any
# real video, builds the cluster tree and queries it with every ingested frame, then measures
# against the clip's true head pose (/frames/pose; pitch > 0 face down, yaw > 0 face to its
# left, the convention of rig::RigidPose that f_pose follows):
#   - f_pose: error of its pitch and yaw (degrees) per frame: mean |error|, bias, RMS,
#     correlation with the truth, mean |error| of the frames with |yaw| < 30 degrees and mean
#     error of those with |yaw| >= 45 (near profile);
#   - queries (picks q = 2, 3, 1 by default): the true pose difference between each query frame
#     and the frames it picks, itself left out (mean |d pitch|, |d yaw|, and the angle
#     between the two head orientations), beside that of random frame pairs;
#   - lighting: the spread of f_lighting (mean distance between two frames of a set) among
#     the q_2 lighting picks of each kept pose node, beside the spread over all frames and
#     over all frames of the same pose node.
# The last line is one JSON object with these figures.
#
#   analysis/curate_accuracy.sh [BUILD_DIR] [-- extra `synth clip` options]
#
# BUILD_DIR defaults to $FACECAP_BUILD_DIR, then build/ under the source tree. FRAMES (default
# 240), SIZE (default 256) and SEED (default 7: identity, motion, lighting, background and
# camera seed) make the clip; PICKS (default 2,3,1) and CLUSTERS (default 9,3) the tree and
# its queries. KEEP=DIR keeps the clip and outputs in DIR.
set -euo pipefail

source_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${FACECAP_BUILD_DIR:-${source_dir}/build}"
if [[ $# -gt 0 && "$1" != "--" ]]; then
  build_dir="$1"
  shift
fi
[[ $# -gt 0 && "$1" == "--" ]] && shift
frames="${FRAMES:-240}"
size="${SIZE:-256}"
seed="${SEED:-7}"
picks="${PICKS:-2,3,1}"
clusters="${CLUSTERS:-9,3}"
python=/usr/bin/python3

facecap="${build_dir}/facecap"
if [[ ! -x "${facecap}" ]]; then
  echo "error: ${facecap} not found; configure and build first (cmake -S . -B build -G Ninja)" >&2
  exit 1
fi
if [[ -n "${KEEP:-}" ]]; then
  work="${KEEP}"
  mkdir -p "${work}"
else
  work="$(mktemp -d)"
  trap 'rm -rf "${work}"' EXIT
fi

run() {  # a facecap command, its log shown only when it fails
  if ! "${facecap}" "$@" >"${work}/step.log" 2>&1; then
    cat "${work}/step.log" >&2
    echo "error: facecap $* failed" >&2
    exit 1
  fi
}

start=${SECONDS}
run rig demo --out "${work}/rig.h5"
run synth clip --rig "${work}/rig.h5" --frames "${frames}" --size "${size}" --video \
  --identity-seed "${seed}" --motion-seed "${seed}" --lighting-seed "${seed}" \
  --background-seed "${seed}" --camera-seed "${seed}" --out "${work}/clip.h5" "$@"
run ingest --video "${work}/clip.mp4" --out "${work}/frames.h5"
grep "ingest summary" "${work}/step.log" | sed 's/.*ingest summary: /# ingest: /'
run curate build --frames "${work}/frames.h5" --out "${work}/curation.h5" --clusters "${clusters}"
run curate query --curation "${work}/curation.h5" --query-frames "${work}/frames.h5" \
  --picks "${picks}" --out "${work}/queries.h5" --sheet "${work}/queries.png"
echo "# ${frames} frames of ${size}x${size}, seed ${seed}, clusters ${clusters}, picks ${picks}: $((SECONDS - start)) s"

"${python}" - "${work}" "${picks}" <<'EOF'
import json
import sys

import h5py
import numpy as np

work, picks = sys.argv[1], [int(q) for q in sys.argv[2].split(",")]
with h5py.File(f"{work}/clip.h5", "r") as f:
    truth = np.degrees(f["/frames/pose"][()][:, :2].astype(np.float64))  # pitch, yaw
with h5py.File(f"{work}/frames.h5", "r") as f:
    source = f["/frames/source_index"][()]
with h5py.File(f"{work}/curation.h5", "r") as f:
    rows = f["/features/frame"][()]
    feature = f["/features/pose"][()].astype(np.float64)
    lighting = f["/features/lighting"][()].astype(np.float64)
    levels = [f[f"/tree/level_{l}/first_child"][()] for l in range(len(f["/tree/levels"]) - 1)]
    parents = [f[f"/tree/level_{l}/parent"][()] for l in range(len(levels))]
    leaf_items = f["/tree/leaf_items"][()]
with h5py.File(f"{work}/queries.h5", "r") as f:
    query_picks = f["/queries/picks"][()]
    offsets = f["/queries/offsets"][()]
    labels = [s.decode() if isinstance(s, bytes) else s for s in f["/queries/labels"][()]]

true = truth[source[rows]]  # true pitch, yaw of every tree item
item_of_row = {int(r): i for i, r in enumerate(rows)}
err = feature - true
out = {"frames": int(len(truth)), "found": int(len(rows))}
print(f"\nf_pose against the true pose, {len(rows)} frames with a face (degrees):")
for k, name in enumerate(("pitch", "yaw")):
    e = err[:, k]
    corr = float(np.corrcoef(feature[:, k], true[:, k])[0, 1])
    frontal = np.abs(true[:, 1]) < 30
    profile = np.abs(true[:, 1]) >= 45
    out[f"{name}_mean_abs_error_deg"] = round(float(np.abs(e).mean()), 2)
    out[f"{name}_bias_deg"] = round(float(e.mean()), 2)
    out[f"{name}_rms_error_deg"] = round(float(np.sqrt((e ** 2).mean())), 2)
    out[f"{name}_corr"] = round(corr, 3)
    out[f"{name}_mean_abs_error_yaw_below_30_deg"] = round(float(np.abs(e[frontal]).mean()), 2)
    out[f"{name}_mean_error_yaw_above_45_deg"] = round(float(e[profile].mean()), 2) if profile.any() else None
    print(f"  {name:>5}: mean |error| {np.abs(e).mean():5.2f}, bias {e.mean():+5.2f}, RMS "
          f"{np.sqrt((e ** 2).mean()):5.2f}, correlation {corr:+.3f}; |yaw| < 30: mean |error| "
          f"{np.abs(e[frontal]).mean():5.2f} ({frontal.sum()} frames); |yaw| >= 45: mean error "
          f"{e[profile].mean() if profile.any() else float('nan'):+6.2f} ({profile.sum()} frames); "
          f"truth spans [{true[:, k].min():.0f}, {true[:, k].max():.0f}]")


def angle(a, b):
    """Angle (degrees) between head orientations R = Ry(yaw) Rx(pitch) at (pitch, yaw) pairs."""
    def forward(p):
        p, y = np.radians(p[..., 0]), np.radians(p[..., 1])
        return np.stack([np.cos(p) * np.sin(y), -np.sin(p), np.cos(p) * np.cos(y)], axis=-1)
    return np.degrees(np.arccos(np.clip((forward(a) * forward(b)).sum(-1), -1, 1)))


# Query pose error: each query frame against the frames it picked (itself left out).
d_pitch, d_yaw, d_angle, counts = [], [], [], []
for i, label in enumerate(labels):
    q_row = int(label.rsplit(" ", 1)[1])
    q = true[item_of_row[q_row]]
    picked = [int(r) for r in query_picks[offsets[i]:offsets[i + 1]] if int(r) != q_row]
    counts.append(offsets[i + 1] - offsets[i])
    for r in picked:
        p = true[item_of_row[r]]
        d_pitch.append(abs(p[0] - q[0]))
        d_yaw.append(abs(p[1] - q[1]))
        d_angle.append(float(angle(p, q)))
rng = np.random.default_rng(0)
a, b = rng.integers(0, len(rows), 20000), rng.integers(0, len(rows), 20000)
random_angle = angle(true[a], true[b])
out.update({
    "queries": len(labels), "picks": picks, "picks_per_query": round(float(np.mean(counts)), 2),
    "query_pick_mean_abs_dpitch_deg": round(float(np.mean(d_pitch)), 2),
    "query_pick_mean_abs_dyaw_deg": round(float(np.mean(d_yaw)), 2),
    "query_pick_mean_angle_deg": round(float(np.mean(d_angle)), 2),
    "query_pick_median_angle_deg": round(float(np.median(d_angle)), 2),
    "random_pair_mean_abs_dyaw_deg": round(float(np.abs(true[a, 1] - true[b, 1]).mean()), 2),
    "random_pair_mean_angle_deg": round(float(random_angle.mean()), 2),
})
print(f"\nqueries: every one of the {len(labels)} frames with a face, picks {picks} "
      f"({np.mean(counts):.1f} frames each); true pose of the picks relative to the query frame "
      f"(the query frame itself left out, degrees):")
print(f"  picks:        mean |d pitch| {np.mean(d_pitch):5.2f}, mean |d yaw| {np.mean(d_yaw):5.2f}, "
      f"head angle mean {np.mean(d_angle):5.2f}, median {np.median(d_angle):5.2f}")
print(f"  random pairs: mean |d pitch| {np.abs(true[a, 0] - true[b, 0]).mean():5.2f}, mean |d yaw| "
      f"{np.abs(true[a, 1] - true[b, 1]).mean():5.2f}, head angle mean {random_angle.mean():5.2f}")

# Lighting spread: per query and kept pose node, the q_2 lighting picks.
pose_node_of_item = np.zeros(len(rows), dtype=int)
if levels:
    last = levels[-1]
    node = np.zeros(len(rows), dtype=int)
    for j in range(len(last) - 1):
        node[leaf_items[last[j]:last[j + 1]]] = j
    for l in range(len(levels) - 1, 0, -1):
        node = parents[l][node]
    pose_node_of_item = node


def spread(x):
    """Mean distance between two different frames of the set (unbiased by the set's size)."""
    if len(x) < 2:
        return float("nan")
    if len(x) > 600:
        x = x[np.random.default_rng(1).choice(len(x), 600, replace=False)]
    d = np.sqrt(((x[:, None, :] - x[None, :, :]) ** 2).sum(-1))
    return float(d.sum() / (len(x) * (len(x) - 1)))


pick_spreads = []
for i in range(len(labels)):
    items = [item_of_row[int(r)] for r in query_picks[offsets[i]:offsets[i + 1]]]
    for n in set(pose_node_of_item[items]):
        group = [t for t in items if pose_node_of_item[t] == n]
        if len(group) > 1:
            pick_spreads.append(spread(lighting[group]))
node_spreads = [spread(lighting[pose_node_of_item == n]) for n in set(pose_node_of_item)
                if (pose_node_of_item == n).sum() > 1]
sizes = [(pose_node_of_item == n).sum() for n in set(pose_node_of_item) if (pose_node_of_item == n).sum() > 1]
out.update({
    "lighting_spread_q2_picks": round(float(np.nanmean(pick_spreads)), 4),
    "lighting_spread_pose_node": round(float(np.average(node_spreads, weights=sizes)), 4),
    "lighting_spread_all_frames": round(spread(lighting), 4),
})
print(f"\nlighting (f_lighting, 36 values in [0, 1]; mean distance between two frames):")
print(f"  among the q_2 lighting picks of a kept pose node: {np.nanmean(pick_spreads):.4f} "
      f"({len(pick_spreads)} groups)")
print(f"  over all frames of the same pose node:           {out['lighting_spread_pose_node']:.4f}")
print(f"  over all frames:                                 {out['lighting_spread_all_frames']:.4f}")
print(json.dumps(out))
EOF
