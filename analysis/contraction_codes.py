#!/usr/bin/python3
"""Which deepfake codes rank the random samples by how much they resemble the footage.

On the demo (jobs/demo.toml, then jobs/dataset.toml's deepfake.infer-samples), every sample's
true parameters and every real frame's true parameters are known. A sample's true distance to
the footage is the mean distance from its parameters (52 weights, pitch and yaw) to those of
the 5 nearest real frames. The script prints the Spearman correlation between that and the
contraction score (the mean distance to the 5 nearest real codes) for the samples' codes
E(I_S) or E(D_A(E(I_S))) against the real frames' E(I_R) or E(D_A(E(I_R))), at several pose
weights of the true distance and numbers of neighbours, and the true distance of the samples
each choice keeps (the 20% highest scores removed) beside that of an oracle removal.

    /usr/bin/python3 analysis/contraction_codes.py [DEMO_DIR] [SAMPLE_CODES]

DEMO_DIR defaults to out/demo, SAMPLE_CODES to out/dataset/samples_codes.h5.
"""
import sys

import h5py
import numpy as np

demo = sys.argv[1] if len(sys.argv) > 1 else "out/demo"
sample_codes = h5py.File(sys.argv[2] if len(sys.argv) > 2 else "out/dataset/samples_codes.h5", "r")
translated = h5py.File(f"{demo}/translated.h5", "r")
clip = h5py.File(f"{demo}/clip.h5", "r")
samples = h5py.File(f"{demo}/samples.h5", "r")

found = translated["/frames/found"][:].astype(bool)
w_real = clip["/frames/weights"][:][found]
p_real = clip["/frames/pose"][:][found][:, :2]
w_s = samples["/samples/weights"][:]
p_s = samples["/samples/pose"][:][:, :2]


def spearman(a, b):
    """Spearman's rank correlation (ties ranked by order; the scores here have none)."""
    ra, rb = np.argsort(np.argsort(a)), np.argsort(np.argsort(b))
    return float(np.corrcoef(ra, rb)[0, 1])


def mean_nearest(d, k):
    return np.sort(d, 1)[:, :k].mean(1)


def code_distance(q, r):
    q, r = q.astype(np.float64), r.astype(np.float64)
    d2 = (q ** 2).sum(1)[:, None] + (r ** 2).sum(1)[None, :] - 2 * q @ r.T
    return np.sqrt(np.maximum(d2, 0))


def true_distance(pose_weight):
    d2 = ((w_s[:, None, :] - w_real[None, :, :]) ** 2).sum(-1)
    d2 += pose_weight * ((p_s[:, None, :] - p_real[None, :, :]) ** 2).sum(-1)
    return mean_nearest(np.sqrt(d2), 5)


names = {"latent": "E(I)", "latent_of_translation": "E(D_A(E(I)))"}
removed = int(round(0.2 * len(w_s)))
print("| samples | real frames | pose weight | k | Spearman | true distance kept (all, oracle) |")
print("| --- | --- | --- | --- | --- | --- |")
for pose_weight in (1, 4, 16):
    truth = true_distance(pose_weight)
    oracle = np.delete(truth, np.argsort(-truth)[:removed]).mean()
    for sample_name in names:
        for real_name in names:
            d = code_distance(sample_codes[f"/frames/{sample_name}"][:],
                              translated[f"/frames/{real_name}"][:][found])
            for k in (1, 5, 20):
                score = mean_nearest(d, k)
                kept = np.delete(truth, np.argsort(-score)[:removed]).mean()
                print(f"| {names[sample_name]} | {names[real_name]} | {pose_weight} | {k} | "
                      f"{spearman(score, truth):+.3f} | {kept:.3f} "
                      f"({truth.mean():.3f}, {oracle:.3f}) |")
