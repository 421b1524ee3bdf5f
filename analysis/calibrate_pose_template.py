#!/usr/bin/python3
"""Calibrates the depths of f_pose's 3D template (src/curate/features.cpp, kStableDepth).

The template's x, y are the frontal mean face (dlib's mean shape) of the 13 expression-stable
landmarks; its depths are fitted here so that f_pose recovers known pitch and yaw on landmarks
projected from the demo rig's own landmark vertices: the neutral demo head posed with
rig::RigidPose's rotation R = Ry(yaw) Rx(pitch) (pitch -20 to 20, yaw -60 to 60 degrees) and
projected through a pinhole camera at the given distance. The depths are kept left-right
symmetric; people made of the demo head with random identity modes are held out. The
estimator is the one of features.cpp (best 2D similarity per candidate pose, least squares),
reimplemented with numpy.

    facecap rig demo --out rig.h5
    analysis/calibrate_pose_template.py rig.h5 [--distance-cm 65]

Prints the fitted depths (mean-face units, centred on the inner eye corners) and the pose
error before and after on the calibration poses and on held-out people.
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
OLD_DEPTH = [0.08, 0.12, 0.18, 0.25, 0.07, 0.11, 0.14, 0.11, 0.07, -0.12, 0.0, 0.0, -0.12]


def rotation(pitch, yaw):
    """rig::RigidPose's Ry(yaw) * Rx(pitch) in the rig's axes (x head's left, y up, z front)."""
    cp, sp, cy, sy = math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    rx = np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    return ry @ rx


def project_rig(points, pitch, yaw, distance):
    """Image points (x right, y down) of rig-space points at a pose, pinhole at `distance`."""
    q = points @ rotation(pitch, yaw).T
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


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("rig")
    ap.add_argument("--distance-cm", type=float, default=65.0,
                    help="camera distance (a framed 20-degree camera: about 65 cm)")
    ap.add_argument("--people", type=int, default=4, help="held-out random identities")
    args = ap.parse_args()
    with h5py.File(args.rig, "r") as f:
        neutral = f["/rig/neutral"][()].astype(np.float64)
        landmarks = f["/rig/landmarks"][()]
        modes = f["/rig/identity_modes"][()].astype(np.float64)
    idx = landmarks[STABLE]
    rng = np.random.default_rng(1)
    mean = neutral[idx]
    held_out = [(neutral + np.tensordot(np.clip(rng.standard_normal(modes.shape[0]), -2.5, 2.5),
                                        modes, axes=1))[idx] for _ in range(args.people)]
    poses = [(p, y) for p in range(-20, 21, 10) for y in range(-60, 61, 15)]

    def samples(group):
        return [(p, y, project_rig(pts, math.radians(p), math.radians(y), args.distance_cm))
                for pts in group for p, y in poses]

    train, test = samples([mean]), samples(held_out)

    def errors(depths, data, warm=False):
        t = template(depths)
        e = []
        for p, y, pts in data:
            ep, ey = estimate(t, pts, (p, y) if warm else None)
            e.append((ep - p, ey - y))
        return np.array(e)

    def report(name, depths):
        for label, data in (("demo rig", train), ("held-out people", test)):
            e = errors(depths, data)
            print(f"{name:>10} {label:>16}: pitch bias {e[:, 0].mean():+.2f} mean |err| "
                  f"{np.abs(e[:, 0]).mean():.2f} max {np.abs(e[:, 0]).max():.2f}; yaw bias "
                  f"{e[:, 1].mean():+.2f} mean |err| {np.abs(e[:, 1]).mean():.2f} max "
                  f"{np.abs(e[:, 1]).max():.2f} (deg)")

    # Initial guess: the rig's own depths, in mean-face units (the similarity that takes the
    # rig's frontal x, y onto the mean face), relative to the inner eye corners.
    frontal = np.stack([mean[:, 0], -mean[:, 1]], axis=1)
    frontal -= frontal.mean(0)
    tmpl = template(OLD_DEPTH)[:, :2]
    scale = np.sqrt((tmpl ** 2).sum() / (frontal ** 2).sum())
    z = (mean[:, 2] - mean[10, 2]) * scale
    v0 = np.array([z[0], z[1], z[2], z[3], z[6], z[9], z[4], z[5]])
    report("old", OLD_DEPTH)
    report("rig z", symmetric_depths(v0))
    fit = least_squares(lambda v: errors(symmetric_depths(v), train, warm=True).ravel(), v0,
                        diff_step=1e-3, max_nfev=80)
    depths = symmetric_depths(fit.x)
    report("fitted", depths)
    print("depths (27 28 29 30 31 32 33 34 35 36 39 42 45):")
    print("{" + ", ".join(f"{d:.3f}" for d in depths) + "}")


if __name__ == "__main__":
    main()
