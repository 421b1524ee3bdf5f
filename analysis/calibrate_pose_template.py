#!/usr/bin/python3
"""Checks, and fits, the depths of f_pose's 3D template (src/curate/features.cpp, kStableDepth)
against synthetic truth.

The template's x, y are the frontal mean face (dlib's mean shape) of the 13 expression-stable
landmarks. Two kinds of truth:
  - the demo rig's own landmark vertices, posed with rig::RigidPose's rotation
    R = Ry(yaw) Rx(pitch) (pitch -20 to 20, yaw -60 to 60 degrees) and projected through a
    pinhole camera framed on the face as render::FramedPose frames it (the centre of the
    landmarks' box on the optical axis) at the given distance; people made of the demo head
    with random identity modes are reported as held out;
  - dlib's landmarks of wild clips (`facecap synth clip --video`, then `facecap ingest` of the
    mp4) against the clip's /frames/pose, frames with |yaw| < 45 degrees (--wild CLIP FRAMES;
    use other seeds than the clip an evaluation runs on).
It fits left-right symmetric depths to the rig's vertices (least squares) and prints the pose
error of the current profile and of that fit on both kinds of truth. The estimator is the one
of features.cpp (best 2D similarity per candidate pose, least squares), reimplemented with
numpy.

    facecap rig demo --out rig.h5
    analysis/calibrate_pose_template.py rig.h5 [--distance-cm 65] [--wild clip.h5 frames.h5 ...]
"""
import argparse
import math

import h5py
import numpy as np
from scipy.optimize import least_squares

STABLE = [27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 39, 42, 45]
# dlib's mean face shape (src/face/landmarks68.cpp) for the 13 points.
MEAN_X = {27: 0.490127, 28: 0.490127, 29: 0.490127, 30: 0.490127, 31: 0.36688, 32: 0.426036,
          33: 0.490127, 34: 0.554217, 35: 0.613373, 36: 0.121737, 39: 0.334606, 42: 0.645647,
          45: 0.858516}
MEAN_Y = {27: 0.203352, 28: 0.307009, 29: 0.409805, 30: 0.515625, 31: 0.587326, 32: 0.609345,
          33: 0.628106, 34: 0.609345, 35: 0.587326, 36: 0.216423, 39: 0.231733, 42: 0.231733,
          45: 0.216423}
CURRENT_DEPTH = [0.08, 0.12, 0.18, 0.25, 0.07, 0.11, 0.14, 0.11, 0.07, -0.12, 0.0, 0.0, -0.12]


def rotation(pitch, yaw):
    """rig::RigidPose's Ry(yaw) * Rx(pitch) in the rig's axes (x head's left, y up, z front)."""
    cp, sp, cy, sy = math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    rx = np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    return ry @ rx


def project_rig(points, pitch, yaw, distance, centre):
    """Image points (x right, y down) of rig-space points at a pose, through a pinhole camera
    framed as render::FramedPose frames a head: `centre` (the centre of the bounding box of
    the 68 landmarks) on the optical axis at `distance`."""
    r = rotation(pitch, yaw)
    q = (points - centre) @ r.T
    depth = distance - q[:, 2]
    return np.stack([q[:, 0] / depth, -q[:, 1] / depth], axis=1)


def template(depths):
    t = np.array([[MEAN_X[i], MEAN_Y[i], d] for i, d in zip(STABLE, depths)])
    return t - t.mean(axis=0)


def project_template(t, pitch, yaw):
    """features.cpp's ProjectPoseTemplate: the same rotation in the template's axes (y down)."""
    cp, sp, cy, sy = math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    rx = np.array([[1, 0, 0], [0, cp, sp], [0, -sp, cp]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    q = t @ (ry @ rx).T
    return q[:, :2]


def similarity_residual(frm, to):
    a = (frm - frm.mean(0))
    b = (to - to.mean(0))
    ac = a[:, 0] + 1j * a[:, 1]
    bc = b[:, 0] + 1j * b[:, 1]
    cross = np.sum(np.conj(ac) * bc)
    return max(0.0, np.sum(np.abs(bc) ** 2) - abs(cross) ** 2 / np.sum(np.abs(ac) ** 2))


def similarity_residuals(frm, to):
    """Residual vector of the best 2D similarity taking `frm` onto `to` (both 13 x 2)."""
    a = frm - frm.mean(0)
    b = to - to.mean(0)
    ac = a[:, 0] + 1j * a[:, 1]
    bc = b[:, 0] + 1j * b[:, 1]
    r = bc - (np.sum(np.conj(ac) * bc) / np.sum(np.abs(ac) ** 2)) * ac
    return np.concatenate([r.real, r.imag])


def estimate(t, points, start=None):
    """(pitch, yaw) in degrees of the template that fits `points` (13 x 2) best: a 10-degree
    grid (or `start`), then least squares."""
    if start is None:
        def cost(v):
            return similarity_residual(project_template(t, math.radians(v[0]), math.radians(v[1])), points)
        best = min(((cost((p, y)), p, y) for p in range(-60, 61, 10) for y in range(-80, 81, 10)))
        start = (best[1], best[2])
    r = least_squares(lambda v: similarity_residuals(
        project_template(t, math.radians(v[0]), math.radians(v[1])), points), start,
        xtol=1e-12, ftol=1e-14, gtol=1e-14)
    return r.x


def symmetric_depths(v):
    """The 13 depths from 8 values: 27, 28, 29, 30, 33, the outer eye corners 36/45, the
    nostril wings 31/35 and 32/34; the inner eye corners 39/42 are the zero."""
    return [v[0], v[1], v[2], v[3], v[6], v[7], v[4], v[7], v[6], v[5], 0.0, 0.0, v[5]]


def load_wild(clip_path, frames_path):
    """(pitch, yaw, 13 dlib landmarks) of the frames of an ingested wild clip, |yaw| < 45."""
    with h5py.File(clip_path, "r") as c, h5py.File(frames_path, "r") as f:
        truth = np.degrees(c["/frames/pose"][()][:, :2].astype(np.float64))
        found = f["/frames/found"][()].astype(bool)
        source = f["/frames/source_index"][()][found]
        points = f["/frames/landmarks"][()][found][:, STABLE].astype(np.float64)
    return [(truth[s, 0], truth[s, 1], p) for s, p in zip(source, points) if abs(truth[s, 1]) < 45]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("rig")
    ap.add_argument("--distance-cm", type=float, default=65.0,
                    help="camera distance (a framed 20-degree camera: about 65 cm)")
    ap.add_argument("--people", type=int, default=4, help="held-out random identities")
    ap.add_argument("--wild", nargs=2, action="append", default=[], metavar=("CLIP", "FRAMES"),
                    help="a wild clip and its ingest output (repeatable)")
    args = ap.parse_args()
    with h5py.File(args.rig, "r") as f:
        neutral = f["/rig/neutral"][()].astype(np.float64)
        landmarks = f["/rig/landmarks"][()]
        modes = f["/rig/identity_modes"][()].astype(np.float64)
    idx = landmarks[STABLE]
    all68 = neutral[landmarks]
    centre = 0.5 * (all68.min(axis=0) + all68.max(axis=0))
    rng = np.random.default_rng(1)
    mean = neutral[idx]
    held_out = [(neutral + np.tensordot(np.clip(rng.standard_normal(modes.shape[0]), -2.5, 2.5),
                                        modes, axes=1))[idx] for _ in range(args.people)]
    poses = [(p, y) for p in range(-20, 21, 10) for y in range(-60, 61, 15)]

    def samples(group):
        return [(p, y, project_rig(pts, math.radians(p), math.radians(y), args.distance_cm, centre))
                for pts in group for p, y in poses]

    truths = [("demo rig vertices", samples([mean])), ("held-out people", samples(held_out))]
    wild = [s for clip, frames in args.wild for s in load_wild(clip, frames)]
    if wild:
        truths.append((f"dlib, wild clips ({len(wild)} frames)", wild))
    train = truths[0][1]

    def errors(depths, data, warm=False):
        t = template(depths)
        e = []
        for p, y, pts in data:
            ep, ey = estimate(t, pts, (p, y) if warm else None)
            e.append((ep - p, ey - y))
        return np.array(e)

    def report(name, depths):
        for label, data in truths:
            e = errors(depths, data)
            print(f"{name:>8} {label:>32}: pitch bias {e[:, 0].mean():+.2f} mean |err| "
                  f"{np.abs(e[:, 0]).mean():.2f}; yaw bias {e[:, 1].mean():+.2f} mean |err| "
                  f"{np.abs(e[:, 1]).mean():.2f} (deg)")

    report("current", CURRENT_DEPTH)
    v0 = np.array([CURRENT_DEPTH[i] for i in (0, 1, 2, 3, 6, 9, 4, 5)])
    fit = least_squares(lambda v: errors(symmetric_depths(v), train, warm=True).ravel(), v0,
                        diff_step=1e-3, max_nfev=80)
    depths = symmetric_depths(fit.x)
    report("fitted", depths)
    print("depths fitted to the rig's vertices (27 28 29 30 31 32 33 34 35 36 39 42 45):")
    print("{" + ", ".join(f"{d:.3f}" for d in depths) + "}")


if __name__ == "__main__":
    main()
