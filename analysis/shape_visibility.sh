#!/usr/bin/env bash
# Which shapes a segmentation image can show: each of a rig's shapes alone at WEIGHT, rendered
# frontally as a segmentation at 128 pixels and shaded at 64 (the deepfake's input size),
# against the neutral; the pixels whose region (segmentation) or colour (shaded, by more than
# 0.05 summed over RGB) change. A shape that changes no region cannot be tracked through the
# segmentation translations, whatever the deepfake. With the demo's outputs, the active-weight
# MAE of its tracks (honest, true rig on the translations, true rig on the true segmentation)
# and of the neutral face is split into the shapes that change at least MIN_PIXELS regions and
# the others. Prints markdown tables.
#
#   analysis/shape_visibility.sh [RIG]
#
# RIG: the rig file (default: DEMO/rig.h5, the demo person's true rig). Environment: DEMO
# (out/demo, the demo's outputs; the split is skipped when its clip.h5 is absent), WEIGHT (0.5),
# MIN_PIXELS (5), WORK (out/shape_visibility), FACECAP_BUILD_DIR (build/).
source "$(dirname "${BASH_SOURCE[0]}")/preamble.sh"
require_facecap
demo="${DEMO:-out/demo}"
rig="${1:-${demo}/rig.h5}"
[[ -f "${rig}" ]] || { echo "error: ${rig}: no such rig file (run jobs/demo.toml, or name a rig)" >&2; exit 2; }
weight="${WEIGHT:-0.5}"
min_pixels="${MIN_PIXELS:-5}"
work="$(mkdir -p "${WORK:-out/shape_visibility}" && cd "${WORK:-out/shape_visibility}" && pwd)"
log() { echo "[shape_visibility] $*" >&2; }

mapfile -t shapes < <(/usr/bin/python3 -c "
import sys, h5py
for n in h5py.File(sys.argv[1], 'r')['/rig/shapes/names'][:]:
    print(n.decode() if isinstance(n, bytes) else n)" "${rig}")
log "${#shapes[@]} shapes of ${rig} at ${weight}"
render() {  # NAME WEIGHTS: segmentation at 128 and shaded at 64
  "${facecap}" render --rig "${rig}" --mode segmentation --size 128 --threads 1 \
    ${2:+--weights "$2"} --out "${work}/$1_segmentation.png" > /dev/null
  "${facecap}" render --rig "${rig}" --mode shaded --size 64 --threads 1 \
    ${2:+--weights "$2"} --out "${work}/$1_shaded.png" > /dev/null
}
render neutral ""
for s in "${shapes[@]}"; do render "shape_${s}" "${s}=${weight}"; done

/usr/bin/python3 - "${work}" "${demo}" "${min_pixels}" "${weight}" "${shapes[@]}" <<'EOF'
import os, sys
import numpy as np
import matplotlib.image as mi

work, demo, min_pixels, weight, shapes = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5:]
def changed(name, mode, threshold):
    a = mi.imread(f"{work}/neutral_{mode}.png")[..., :3]
    b = mi.imread(f"{work}/shape_{name}_{mode}.png")[..., :3]
    return int((np.abs(a - b).sum(2) > threshold).sum())
seg = np.array([changed(s, "segmentation", 0.01) for s in shapes])
shaded = np.array([changed(s, "shaded", 0.05) for s in shapes])
print(f"| shape (alone at {weight}) | regions changed, 128 px | colours changed, shaded 64 px |")
print("| --- | --- | --- |")
for k in np.argsort(seg, kind="stable"):
    print(f"| {shapes[k]} | {seg[k]} | {shaded[k]} |")
shown = seg >= min_pixels
print(f"\n{shown.sum()} of {len(shapes)} shapes change at least {min_pixels} pixels' regions.")

clip = os.path.join(demo, "clip.h5")
if not os.path.exists(clip):
    sys.exit(0)
import h5py
with h5py.File(clip, "r") as f:
    truth = f["frames/weights"][:]
    names = [n.decode() if isinstance(n, bytes) else n for n in f["frames/shape_names"][:]]
if names != shapes:
    sys.exit(f"error: {clip} names other shapes than the rig")
with h5py.File(os.path.join(demo, "frames.h5"), "r") as f:
    found = f["frames/found"][:].astype(bool)
rows = [("neutral face", np.zeros_like(truth))]
for label, name in [("honest", "track.h5"), ("true rig on the translations", "track_truerig.h5"),
                    ("true rig on the true segmentation", "track_oracle.h5")]:
    path = os.path.join(demo, name)
    if os.path.exists(path):
        with h5py.File(path, "r") as f:
            index = f["track/source_index"][:]
            tracked = np.zeros_like(truth)
            tracked[index] = f["track/weights"][:]
        rows.append((label, tracked))
w = truth[found]
active = w > 0.1
print(f"\nActive-weight MAE (true weight > 0.1) over the {found.sum()} frames with a face:\n")
print(f"| | all shapes ({active.sum()} active) | shapes shown ({active[:, shown].sum()}) | "
      f"shapes hidden ({active[:, ~shown].sum()}) |")
print("| --- | --- | --- | --- |")
for label, tracked in rows:
    e = np.abs(tracked[found] - w)
    part = lambda mask: f"{e[:, mask][active[:, mask]].mean():.3f}" if active[:, mask].any() else "-"
    print(f"| {label} | {e[active].mean():.3f} | {part(shown)} | {part(~shown)} |")
EOF
