#!/usr/bin/env bash
# The personalized regressor (paper 000 Sec. 9) against the truth, on the demo clip (whose
# frames the tracker's solutions trained on) and on two held-out clips of the same person that
# neither the deepfake nor phase 1 saw, the second with extreme yaws: per frame the yaw of the
# truth, of the regressor trained on the random samples alone (the paper's stage 1), of the
# same after phases 2-3 (stage 3: the three clips' landmarks as weak supervision), of the
# regressor trained on the contracted and expanded samples and the tracker's solutions of the
# demo clip and two more (the one the job delivers), of the landmarks-only fit and of the
# tracker (paper Fig. 24, as a plot and tables), and each one's pose error, weight MAE,
# landmark NME and seconds per frame, beside the neutral face; then stage 3 against stage 1
# over the frames with |yaw| > 40 deg.
#
#   analysis/regressor_yaw.sh [BUILD_DIR]
#
# Runs jobs/regress.toml (about 33 minutes on 2 cores; run jobs/demo.toml first) and writes
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

def rows_of(prefix):
    return [("landmarks-only fit", f"out/regress/{prefix}track_landmarks.h5", f"out/regress/{prefix}metrics_landmarks.json"),
            ("regressor, random samples alone (stage 1)", f"out/regress/{prefix}track_samples.h5",
             f"out/regress/{prefix}metrics_samples.json"),
            ("regressor, stage 1 + phases 2-3 (stage 3)", f"out/regress/{prefix}track_stage3.h5",
             f"out/regress/{prefix}metrics_stage3.json"),
            ("regressor, expanded samples + tracker", f"out/regress/{prefix}track.h5", f"out/regress/{prefix}metrics.json"),
            ("tracker", f"out/regress/{prefix}track_tracker.h5" if prefix else "out/demo/track.h5",
             f"out/regress/{prefix}metrics_tracker.json" if prefix else "out/demo/metrics.json")]

clips = [("the demo clip", "out/demo/clip.h5", "out/demo/frames.h5", rows_of("")),
         ("the held-out clip", "out/regress/holdout.h5", "out/regress/holdout_frames.h5", rows_of("holdout_")),
         ("the extreme-yaw held-out clip", "out/regress/extreme.h5", "out/regress/extreme_frames.h5", rows_of("extreme_"))]
colors = ["tab:blue", "tab:green", "tab:red", "tab:orange", "tab:gray"]
fig, axes = plt.subplots(3, 1, figsize=(10, 11))
extreme_errors = {}  # method -> yaw errors over the frames with |yaw| > 40 deg, every clip
for (title, clip, frames_file, rows), ax in zip(clips, axes):
    truth = np.degrees(h5py.File(clip, "r")["/frames/pose"][:, 1])
    found = h5py.File(frames_file, "r")["/frames/found"][:].astype(bool)
    extreme = found & (np.abs(truth) > 40)
    print(f"## {title}: {found.sum()} frames with a face ({(~found).sum()} without, not scored); "
          f"{extreme.sum()} of them with |yaw| > 40 deg")
    print()
    print("| method | yaw err, all (deg) | yaw err, abs(yaw) > 40 (deg) | pose err (deg) | weight MAE "
          "| active MAE | landmark NME | s / frame |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    first = json.load(open(rows[0][2]))
    print(f"| neutral face | | | | {first['weights_mae_neutral']:.4f} | "
          f"{first['active_weights_mae_neutral']:.3f} | | |")
    frames = np.arange(len(truth))
    ax.plot(frames, truth, "k-", lw=2, label="truth")
    for (name, track, metrics), color in zip(rows, colors):
        yaw = np.degrees(h5py.File(track, "r")["/track/pose"][:, 1])
        m = json.load(open(metrics))
        err = np.abs(yaw - truth)
        extreme_errors.setdefault(name, []).extend(err[extreme])
        print(f"| {name} | {err[found].mean():.2f} | {err[extreme].mean():.2f} | "
              f"{m['pose_err_deg_mean']:.2f} | {m['weights_mae']:.4f} | {m['active_weights_mae']:.3f} | "
              f"{100 * m['landmark_nme']:.2f}% | {m['sec_per_frame']:.4f} |")
        ax.plot(frames, np.where(found, yaw, np.nan), "-", color=color, lw=1, label=name)
    print()
    ax.set_xlabel("frame")
    ax.set_ylabel("yaw (deg)")
    ax.set_title(f"Yaw per frame on {title} (frames without a face left out)")
    ax.legend(fontsize=7)
first, third = (np.mean(extreme_errors[rows[k][0]]) for k in (1, 2))
print(f"Over the {len(extreme_errors[rows[1][0]])} frames with |yaw| > 40 deg of the three clips: stage 1 "
      f"{first:.2f} deg, stage 3 {third:.2f} deg ({100 * (third / first - 1):+.0f}%), landmarks-only fit "
      f"{np.mean(extreme_errors[rows[0][0]]):.2f} deg")
fig.tight_layout()
fig.savefig("out/regress/yaw.png", dpi=120)
print("plot: out/regress/yaw.png")
EOF
