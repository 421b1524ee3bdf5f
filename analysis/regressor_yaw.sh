#!/usr/bin/env bash
# The personalized regressor (paper 000 Sec. 9) against the clip's truth on the demo: per
# frame the yaw of the truth, of the stage-1 regressor (synthetic truth alone), of the final
# regressor (stage 3: the real frames' landmarks as weak supervision), of the landmarks-only
# fit and of the tracker (paper Fig. 24, as a plot and a table), and each one's pose error,
# weight MAE, landmark NME and seconds per frame, beside the neutral face.
#
#   analysis/regressor_yaw.sh [BUILD_DIR]
#
# Runs jobs/regress.toml (about 10 minutes on 2 cores; run jobs/demo.toml first) and writes
# out/regress/yaw.png. Environment: RANKS (2), FACECAP_BUILD_DIR (build/).
source "$(dirname "${BASH_SOURCE[0]}")/preamble.sh"
take_build_dir "$@"
require_facecap
ranks="${RANKS:-2}"
cd "${source_dir}"
for f in deepfake.h5 translated.h5 frames.h5 track.h5 person.h5 clip.h5 metrics.json; do
  [[ -f "out/demo/${f}" ]] || { echo "error: out/demo/${f} missing: run jobs/demo.toml first" >&2; exit 1; }
done
mkdir -p out/regress
"${mpirun_cmd[@]}" -n "${ranks}" "${facecap}" run jobs/regress.toml >out/regress/run.log 2>&1 ||
  { echo "error: jobs/regress.toml failed; see out/regress/run.log" >&2; exit 1; }

/usr/bin/python3 - <<'EOF'
import json
import h5py
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

truth = np.degrees(h5py.File("out/demo/clip.h5", "r")["/frames/pose"][:, 1])
found = h5py.File("out/demo/frames.h5", "r")["/frames/found"][:].astype(bool)
rows = [("landmarks-only fit", "out/regress/track_landmarks.h5", "out/regress/metrics_landmarks.json"),
        ("regressor, stage 1", "out/regress/track.h5", "out/regress/metrics.json"),
        ("regressor, stage 3", "out/regress/track_stage3.h5", "out/regress/metrics_stage3.json"),
        ("tracker (the demo's)", "out/demo/track.h5", "out/demo/metrics.json")]
extreme = found & (np.abs(truth) > 40)
print(f"{found.sum()} frames with a face ({(~found).sum()} without, not scored); "
      f"{extreme.sum()} of them with |yaw| > 40 deg")
print()
print("| method | yaw err, all (deg) | yaw err, abs(yaw) > 40 (deg) | pose err (deg) | weight MAE "
      "| active MAE | landmark NME | s / frame |")
print("| --- | --- | --- | --- | --- | --- | --- | --- |")
first = json.load(open(rows[0][2]))
print(f"| neutral face | | | | {first['weights_mae_neutral']:.4f} | "
      f"{first['active_weights_mae_neutral']:.3f} | | |")
yaws = {}
for name, track, metrics in rows:
    yaw = np.degrees(h5py.File(track, "r")["/track/pose"][:, 1])
    yaws[name] = yaw
    m = json.load(open(metrics))
    err = np.abs(yaw - truth)
    print(f"| {name} | {err[found].mean():.2f} | {err[extreme].mean():.2f} | "
          f"{m['pose_err_deg_mean']:.2f} | {m['weights_mae']:.4f} | {m['active_weights_mae']:.3f} | "
          f"{100 * m['landmark_nme']:.2f}% | {m['sec_per_frame']:.4f} |")

fig, ax = plt.subplots(figsize=(10, 4))
frames = np.arange(len(truth))
ax.plot(frames, truth, "k-", lw=2, label="truth")
for (name, _, _), color in zip(rows, ["tab:blue", "tab:green", "tab:red", "tab:gray"]):
    yaw = np.where(found, yaws[name], np.nan)
    ax.plot(frames, yaw, "-", color=color, lw=1, label=name)
ax.set_xlabel("frame")
ax.set_ylabel("yaw (deg)")
ax.set_title("Yaw per frame on the demo clip (frames without a face left out)")
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig("out/regress/yaw.png", dpi=120)
print()
print("plot: out/regress/yaw.png")
EOF
