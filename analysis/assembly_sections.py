#!/usr/bin/python3
"""Cross-sections of an assembled rig (facecap assemble): the face and its secondary parts cut
by a sagittal plane through the left eye and through the mouth, in a few poses, as one PNG.
Shows at a glance whether the lids close over the eyeball, the lashes sit on the lid margins,
and the teeth and tongue stay inside the mouth and follow the jaw.

    /usr/bin/python3 analysis/assembly_sections.py assembled.h5 sections.png

The rig must be linear (no jaw skinning), as blendshapes infer and textures infer write it.
"""
import argparse

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

COLOURS = {"face": "#c08060", "eye": "#4060c0", "cornea": "#80c0ff", "lacrimal": "#40a0a0",
           "lashes": "#202020", "teeth": "#d0c890", "gums": "#d04060", "tongue": "#a02020"}
POSES = [("neutral", {}), ("eyeBlinkLeft", {"eyeBlinkLeft": 1}), ("eyeLookUpLeft", {"eyeLookUpLeft": 1}),
         ("jawOpen", {"jawOpen": 1}), ("jawOpen + tongueOut", {"jawOpen": 1, "tongueOut": 1})]


def read(path):
    f = h5py.File(path, "r")
    r = f["rig"]
    if "jaw/weights" in r and np.any(r["jaw/weights"][()] > 0):
        raise SystemExit(f"{path}: a rig with jaw skinning; this script draws linear rigs only")
    names = [n.decode() if isinstance(n, bytes) else n for n in r["shapes/names"][()]]
    offsets = r["shapes/deltas/row_offsets"][()]
    vertex = r["shapes/deltas/vertex"][()]
    offset = r["shapes/deltas/offset"][()]
    neutral = r["neutral"][()]
    face = {"neutral": neutral, "triangles": r["triangles"][()], "shapes": {}}
    for s, name in enumerate(names):
        d = np.zeros_like(neutral)
        d[vertex[offsets[s]:offsets[s + 1]]] = offset[offsets[s]:offsets[s + 1]]
        face["shapes"][name] = d
    parts = []
    part_names = [n.decode() if isinstance(n, bytes) else n for n in f["parts/names"][()]]
    for n in part_names:
        g = f["parts"][n]
        material = g.attrs["material"]
        material = material.decode() if isinstance(material, bytes) else material
        parts.append({"name": n, "material": material, "neutral": g["neutral"][()],
                      "triangles": g["triangles"][()], "deltas": g["deltas"][()]})
    shape_names = [n.decode() if isinstance(n, bytes) else n for n in f["parts/shape_names"][()]]
    return face, parts, shape_names


def pose_face(face, weights):
    v = face["neutral"].copy()
    for name, w in weights.items():
        v += w * face["shapes"][name]
    return v


def pose_part(part, shape_names, weights):
    v = part["neutral"].copy()
    for name, w in weights.items():
        v += w * part["deltas"][shape_names.index(name)]
    return v


def section(vertices, triangles, x0):
    """Segments (z, y) where the triangles cross the plane x = x0."""
    segments = []
    d = vertices[:, 0] - x0
    for tri in triangles:
        s = d[tri]
        if s.min() > 0 or s.max() < 0:
            continue
        points = []
        for a, b in ((0, 1), (1, 2), (2, 0)):
            da, db = s[a], s[b]
            if (da > 0) != (db > 0):
                t = da / (da - db)
                p = vertices[tri[a]] + t * (vertices[tri[b]] - vertices[tri[a]])
                points.append((p[2], p[1]))
        if len(points) == 2:
            segments.append(points)
    return segments


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("assembled")
    parser.add_argument("out")
    a = parser.parse_args()
    face, parts, shape_names = read(a.assembled)
    eye = next(p for p in parts if p["name"] == "left_eyeball")["neutral"]
    eye_centre = 0.5 * (eye.min(axis=0) + eye.max(axis=0))
    teeth = next(p for p in parts if p["name"] == "upper_teeth")["neutral"]
    mouth = 0.5 * (teeth.min(axis=0) + teeth.max(axis=0))
    cuts = [("left eye", eye_centre[0], eye_centre, 2.4), ("mouth", 0.0, mouth - np.array([0, 3.0, 1.5]), 7.0)]
    fig, axes = plt.subplots(len(cuts), len(POSES), figsize=(3.2 * len(POSES), 3.4 * len(cuts)))
    for row, (label, x0, centre, half) in enumerate(cuts):
        for col, (title, weights) in enumerate(POSES):
            ax = axes[row, col]
            if all(k in face["shapes"] for k in weights):
                items = [("face", pose_face(face, weights), face["triangles"])]
                items += [(p["material"], pose_part(p, shape_names, weights), p["triangles"]) for p in parts]
                for material, v, t in items:
                    for (z0, y0), (z1, y1) in section(v, t, x0):
                        ax.plot([z0, z1], [y0, y1], color=COLOURS.get(material, "k"), lw=1.0)
            ax.set_xlim(centre[2] - half, centre[2] + half)
            ax.set_ylim(centre[1] - half, centre[1] + half)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"{label}: {title}", fontsize=9)
    handles = [plt.Line2D([], [], color=c, label=m) for m, c in COLOURS.items()]
    fig.legend(handles=handles, loc="lower center", ncol=len(COLOURS), fontsize=8, frameon=False)
    fig.suptitle("sagittal sections (face towards the right)", fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 0.97))
    fig.savefig(a.out, dpi=110)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
