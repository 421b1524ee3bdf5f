#!/usr/bin/python3
"""Dynamic textures (paper 001 eq. 10-13, and the strain texture's reference influences)
written out directly in numpy, against what `facecap eval textures --maps MAPS` wrote, and a
contact sheet of one held-out person's expressions with the true, dynamic (the strain texture),
eq. 14 as printed, predicted (the strain texture of the networks' library, when MAPS has them),
static and per-blendshape textures.

    /usr/bin/python3 analysis/dynamic_textures.py SCANS MAPS [--sheet SHEET.png]

Eq. 10-11 from the person's scan meshes in SCANS (one-ring mean edge lengths), eq. 12-13 from
the per-texel influences and true expression textures in MAPS; prints the largest absolute
differences, and exits 1 when one is above 1e-6 (relative to the largest value).
"""
import argparse
import sys

import h5py
import numpy as np


def mean_edge_lengths(vertices, triangles):
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    length = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    total = np.zeros(len(vertices))
    count = np.zeros(len(vertices))
    for end in (0, 1):
        np.add.at(total, edges[:, end], length)
        np.add.at(count, edges[:, end], 1)
    return np.where(count > 0, total / np.maximum(count, 1), 0.0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scans")
    ap.add_argument("maps")
    ap.add_argument("--sheet", default="", help="contact sheet PNG (empty: none)")
    args = ap.parse_args()
    scans = h5py.File(args.scans, "r")
    maps = h5py.File(args.maps, "r")
    person = int(maps["library/compress"].attrs["person"])
    b = float(maps["library/compress"].attrs["sharpness_per_cm"])
    triangles = scans["template/triangles"][:].astype(np.int64)
    neutral = scans["scans/people/neutral"][person].astype(np.float64)
    expressions = scans["scans/people/expressions"][person].astype(np.float64)

    # Eq. 10-11 per vertex.
    en = mean_edge_lengths(neutral, triangles)
    direct = []
    for e in expressions:
        ep = mean_edge_lengths(e, triangles)
        direct.append(np.stack([np.where(ep < en, en - ep, 0.0), np.where(ep > en, ep - en, 0.0)], axis=-1))
    direct = np.array(direct)
    stored = maps["influence/vertex"][:]
    err_10_11 = np.abs(direct - stored).max()
    scale_10_11 = np.abs(direct).max()

    # Eq. 12-13 per texel.
    influence = maps["influence/texel"][:].astype(np.float64)       # K, S, S, 2
    truth = maps["textures/truth"][:].astype(np.float64)             # K, S, S, C
    worst_12_13, scale_12_13 = 0.0, np.abs(truth).max()
    for kind, name in ((0, "compress"), (1, "stretch")):
        z = b * influence[..., kind]
        w = np.exp(z - z.max(axis=0, keepdims=True))
        w /= w.sum(axis=0, keepdims=True)                            # eq. 12
        blended = (w[..., None] * truth).sum(axis=0)                 # eq. 13
        worst_12_13 = max(worst_12_13, np.abs(blended - maps["library/" + name][:]).max())
        # The reference influence: eq. 13 applied to the influences themselves.
        reference = (w * influence[..., kind]).sum(axis=0)
        worst_12_13 = max(worst_12_13, np.abs(reference - maps["library/reference"][..., kind]).max())

    print(f"person {person}, {len(expressions)} expressions, sharpness {b:g} per cm")
    print(f"eq. 10-11: largest difference {err_10_11:.3g} cm (largest influence {scale_10_11:.3g} cm)")
    print(f"eq. 12-13 and the reference influences: largest difference {worst_12_13:.3g} "
          f"(largest texture value {scale_12_13:.3g})")
    ok = err_10_11 <= 1e-6 * max(scale_10_11, 1.0) and worst_12_13 <= 1e-6 * max(scale_12_13, 1.0)

    if args.sheet:
        sheet(scans, maps, args.sheet)
    return 0 if ok else 1


def sheet(scans, maps, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = [n.decode() if isinstance(n, bytes) else n for n in scans["scans/facs/names"][:]]
    truth = maps["textures/truth"][:]
    rows = [("truth", truth), ("dynamic (strain)", maps["textures/dynamic"][:]),
            ("eq. 14 as printed", maps["textures/as_printed"][:]),
            ("static neutral", np.broadcast_to(maps["library/neutral"][:], truth.shape)),
            ("per-blendshape maps", maps["textures/per_blendshape"][:])]
    if "textures/predicted" in maps:
        rows.insert(3, ("dynamic (strain, predicted)", maps["textures/predicted"][:]))
    neutral = maps["library/neutral"][:]
    # The expressions that change the displacement most.
    change = np.abs(truth[..., 4] - neutral[None, ..., 4]).sum(axis=(1, 2))
    picks = list(np.argsort(-change)[:5])
    S = truth.shape[1]
    y0, y1, x0, x1 = int(0.1 * S), int(0.75 * S), int(0.2 * S), int(0.8 * S)   # the face in the UV layout
    fig, axes = plt.subplots(2 * len(rows), len(picks), figsize=(2.4 * len(picks), 2.1 * 2 * len(rows)))
    lo, hi = np.percentile(truth[..., 4], 0.5), np.percentile(truth[..., 4], 99.5)
    for c, k in enumerate(picks):
        for r, (label, data) in enumerate(rows):
            albedo = np.clip(data[k, y0:y1, x0:x1, :3], 0, 1) ** (1 / 2.2)
            axes[2 * r, c].imshow(albedo)
            axes[2 * r + 1, c].imshow(data[k, y0:y1, x0:x1, 4], cmap="gray", vmin=lo, vmax=hi)
            if c == 0:
                axes[2 * r, c].set_ylabel(label + "\nalbedo", fontsize=8)
                axes[2 * r + 1, c].set_ylabel(label + "\ndisplacement", fontsize=8)
        axes[0, c].set_title(names[k], fontsize=9)
    for a in axes.flat:
        a.set_xticks([])
        a.set_yticks([])
    fig.suptitle("held-out person: true, dynamic (strain texture, library of the other expressions), eq. 14 as "
                 "printed,\ndynamic from the networks' predicted textures, static and per-blendshape textures",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    fig.savefig(path, dpi=80)
    print(f"contact sheet -> {path}")


if __name__ == "__main__":
    sys.exit(main())
