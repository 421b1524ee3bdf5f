#!/usr/bin/python3
"""Plots of a tracking run against the truth, as PNG files.

  yaw.png          tracked yaw against the true yaw over the clip (paper 000 Fig. 24)
  errors.png       per-frame pose error (deg) and weight error (mean absolute) over time

Usage: analysis/plot_track.py --truth clip.h5 --track track.h5 --out plots/
Dataset names default to facecap's layout and can be changed with the flags below.
Needs Debian's python3-h5py and python3-matplotlib (run with /usr/bin/python3).
"""
import argparse
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read(path, name):
    with h5py.File(path, "r") as f:
        if name not in f:
            sys.exit(f"plot_track: {path}: no dataset {name}")
        return f[name][()]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--truth", required=True, help="clip with the true parameters (HDF5)")
    p.add_argument("--track", required=True, help="tracking output (HDF5)")
    p.add_argument("--out", default="plots", help="output folder")
    p.add_argument("--truth-pose", default="/frames/pose")
    p.add_argument("--truth-weights", default="/frames/weights")
    p.add_argument("--truth-names", default="/frames/shape_names")
    p.add_argument("--track-pose", default="/track/pose")
    p.add_argument("--track-weights", default="/track/weights")
    p.add_argument("--track-names", default="/track/shape_names")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)

    true_pose = np.degrees(read(a.truth, a.truth_pose))
    track_pose = np.degrees(read(a.track, a.track_pose))
    n = min(len(true_pose), len(track_pose))
    true_pose, track_pose = true_pose[:n], track_pose[:n]
    frames = np.arange(n)

    fig, ax = plt.subplots(figsize=(9, 3.5))
    ax.plot(frames, true_pose[:, 1], label="true yaw", color="black", linewidth=1.5)
    ax.plot(frames, track_pose[:, 1], label="tracked yaw", color="tab:red", linewidth=1, linestyle="--")
    ax.set_xlabel("frame")
    ax.set_ylabel("yaw (deg)")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "yaw.png"), dpi=120)

    pose_err = np.abs(track_pose - true_pose).max(axis=1)
    true_names = [s.decode() if isinstance(s, bytes) else s for s in read(a.truth, a.truth_names)]
    track_names = [s.decode() if isinstance(s, bytes) else s for s in read(a.track, a.track_names)]
    tw = read(a.truth, a.truth_weights)[:n]
    kw = read(a.track, a.track_weights)[:n]
    common = [name for name in track_names if name in true_names]
    ti = [true_names.index(c) for c in common]
    ki = [track_names.index(c) for c in common]
    weight_err = np.abs(kw[:, ki] - tw[:, ti]).mean(axis=1)

    fig, ax = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    ax[0].plot(frames, pose_err, color="tab:blue")
    ax[0].set_ylabel("pose error (deg)")
    ax[0].grid(alpha=0.3)
    ax[1].plot(frames, weight_err, color="tab:green")
    ax[1].set_ylabel("weight MAE")
    ax[1].set_xlabel("frame")
    ax[1].grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "errors.png"), dpi=120)
    print(f"plot_track: {n} frames -> {a.out}/yaw.png, {a.out}/errors.png "
          f"(mean pose error {pose_err.mean():.2f} deg, mean weight MAE {weight_err.mean():.3f})")


if __name__ == "__main__":
    main()
