#!/usr/bin/python3
"""What a method that sees only a person's neutral can reach on a synthetic scan database.

`facecap scans synth` makes each person's true shapes from the terms documented in
src/assets/scan_database.h (on the personal vertices x, s = personal_strength):

    S_i^j(x) = (1 + e_ij) [ S_i(x) + s (g_ij f_ij(x) S_i(x) + h_ij(x) - S_i(x)) ]

f and h are functions of the neutral at x, g_ij = 1 + 0.25 tanh(c_i . a_j) of the person's
identity, and e_ij is noise no neutral can predict. The database stores g and e
(/scans/truth/global_factors, /scans/truth/personal_factors), so the shapes of methods that
know more than any real one can be built and scored with the same reconstruction error as
`facecap eval blendshapes` (weights in [0, 1] by bounded least squares, then the mean
per-vertex distance over the vertices the template shapes move, in mm), on the held-out
people:

  truth                 the true shapes: the floor that scan noise and unwanted motion leave
  truth without e       g, f and h exact, e = 0: the best any neutral-only method can do
  form + g learnt       f and h exact, g_ij learnt from the training people's g(1 + e) by the
                        best of a ridge regression on the whitened principal components of
                        their neutrals and a fit of the tanh form (the ridge strength chosen
                        on the held-out people: optimistic, so the row is a bound)
  form + g = 1          f and h exact, no global factor
  ours, ours scaled     with --shapes (from `eval blendshapes --shapes`): the generator's
                        shapes, and the same with each shape scaled per person by the factor
                        that brings it closest to the truth (its error with an oracle factor)

Usage: analysis/blendshapes_ceiling.py --scans scans.h5 [--shapes shapes.h5] [--json]
Exit codes: 0 done, 2 usage, 3 the file is not a synthetic database this script understands.
Needs Debian's python3-h5py (run with /usr/bin/python3).
"""
import argparse
import json
import sys

import h5py
import numpy as np


def fail(message):
    print(f"blendshapes_ceiling: {message}", file=sys.stderr)
    sys.exit(3)


def template_deltas(f, path):
    """The template shapes S_i as a dense [N, V, 3] array (stored as per-shape sparse rows)."""
    rows = f["/template/shapes/deltas/row_offsets"][:]
    vertex = f["/template/shapes/deltas/vertex"][:]
    offset = f["/template/shapes/deltas/offset"][:]
    num_vertices = f["/template/neutral"].shape[0]
    out = np.zeros((len(rows) - 1, num_vertices, 3))
    for i in range(len(rows) - 1):
        out[i, vertex[rows[i]:rows[i + 1]]] = offset[rows[i]:rows[i + 1]]
    if not np.isfinite(out).all():
        fail(f"{path}: /template/shapes/deltas holds non-finite values")
    return out


def personal_terms(template, template_neutral, neutral):
    """f_ij(x) [N, V] and h_ij(x) [N, V, 3] of scan_database.h for one neutral."""
    d = neutral - template_neutral
    t_norm = np.linalg.norm(template, axis=2)
    direction = template / np.maximum(t_norm, 1e-30)[..., None]
    local = 1.0 + 0.35 * np.tanh(2.0 * np.einsum("vc,nvc->nv", d, direction))
    d_norm = np.linalg.norm(d, axis=1)
    unit = np.where(d_norm[:, None] > 1e-6, d / np.maximum(d_norm, 1e-30)[:, None], 0.0)
    bend = 0.3 * t_norm[..., None] * np.tanh(d_norm / 0.5)[None, :, None] * unit[None]
    return local, bend


def personal_shapes(template, local, bend, personal, strength, g, e):
    """S_i^j of scan_database.h for factors g [N] and e [N]."""
    out = template.copy()
    t = template[:, personal]
    form = t + strength * (g[:, None, None] * local[:, personal, None] * t + bend[:, personal] - t)
    out[:, personal] = (1.0 + e)[:, None, None] * form
    return out


def reconstruction_errors(neutral, deltas, expressions, moving, sweeps=500, tolerance=1e-7):
    """Per-expression error (mm) of eval blendshapes: bounded least squares in [0, 1] by
    projected coordinate descent over the weights, then the mean per-vertex distance."""
    basis = deltas[:, moving].reshape(deltas.shape[0], -1).T
    targets = (expressions - neutral)[:, moving].reshape(expressions.shape[0], -1).T
    gram = basis.T @ basis
    rhs = basis.T @ targets
    w = np.zeros(rhs.shape)
    diagonal = np.diag(gram)
    for _ in range(sweeps):
        moved = 0.0
        for i in range(len(w)):
            if diagonal[i] <= 0:
                continue
            new = np.clip((rhs[i] - gram[i] @ w + diagonal[i] * w[i]) / diagonal[i], 0.0, 1.0)
            moved = max(moved, float(np.abs(new - w[i]).max()))
            w[i] = new
        if moved <= tolerance:
            break
    residual = (basis @ w - targets).T.reshape(expressions.shape[0], -1, 3)
    return 10.0 * np.linalg.norm(residual, axis=2).mean(axis=1)


def fit_tanh(z, y, lam, iterations=200):
    """g - 1 = b tanh(z w) (z with a ones column) by damped Gauss-Newton with a ridge on w."""
    p = z.shape[1]
    theta = np.zeros(p + 1)
    theta[:p] = np.linalg.solve(z.T @ z + lam * np.eye(p), z.T @ (y / 0.25))
    theta[p] = 0.25
    penalty = lam * 0.0625 * np.eye(p + 1)
    penalty[p - 1, p - 1] = penalty[p, p] = 0.0

    def cost(th):
        r = th[p] * np.tanh(z @ th[:p]) - y
        return r @ r + th @ penalty @ th, r

    damping = 1e-2
    current, r = cost(theta)
    for _ in range(iterations):
        t = np.tanh(z @ theta[:p])
        jac = np.hstack([(theta[p] * (1 - t * t))[:, None] * z, t[:, None]])
        step = np.linalg.lstsq(jac.T @ jac + penalty + damping * np.eye(p + 1), jac.T @ r + penalty @ theta,
                               rcond=None)[0]
        trial, trial_r = cost(theta - step)
        if trial < current:
            theta, current, r, damping = theta - step, trial, trial_r, damping * 0.5
        else:
            damping *= 4.0
    return theta


def learnt_factors(displacements, observed, train, test, true_g):
    """g of the held-out people learnt from the training people's observed g(1 + e): the
    estimator and ridge strength with the lowest mean |g - g_true| on the held-out people."""
    mean = displacements[train].mean(axis=0)
    _, sv, vt = np.linalg.svd(displacements[train] - mean, full_matrices=False)
    rank = int((sv > 1e-6 * sv[0]).sum())
    z = (displacements - mean) @ vt[:rank].T / sv[:rank] * np.sqrt(train.sum())
    z = np.hstack([z, np.ones((len(z), 1))])
    moved = observed[train].std(axis=0) > 0
    best = None
    for name in ("ridge", "tanh"):
        for lam in (0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0):
            g = np.ones_like(observed)
            if name == "ridge":
                reg = lam * np.eye(z.shape[1])
                reg[-1, -1] = 0.0
                w = np.linalg.solve(z[train].T @ z[train] + reg, z[train].T @ (observed[train] - 1.0))
                g = 1.0 + z @ w
            else:
                for i in np.where(moved)[0]:
                    th = fit_tanh(z[train], observed[train, i] - 1.0, lam)
                    g[:, i] = 1.0 + th[-1] * np.tanh(z @ th[:-1])
            error = float(np.abs(g[test][:, moved] - true_g[test][:, moved]).mean())
            if best is None or error < best[0]:
                best = (error, name, lam, g)
    return best


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    parser.add_argument("--scans", required=True, help="synthetic scan database (facecap scans synth)")
    parser.add_argument("--shapes", help="shapes and errors written by facecap eval blendshapes --shapes")
    parser.add_argument("--json", action="store_true", help="also print one JSON object")
    args = parser.parse_args()
    try:
        f = h5py.File(args.scans, "r")
    except OSError as error:
        fail(f"{args.scans}: cannot open as HDF5 ({error})")
    for name in ("/scans/truth/deltas", "/scans/truth/global_factors", "/scans/truth/personal_factors",
                 "/scans/truth/personal_vertices"):
        if name not in f:
            fail(f"{args.scans}: no {name} (imported scans have no truth; databases made before the "
                 "factors were stored need `facecap scans synth` again)")
    template = template_deltas(f, args.scans)
    template_neutral = f["/template/neutral"][:].astype(np.float64)
    personal = f["/scans/truth/personal_vertices"][:]
    strength = float(f["/scans/truth/personal_vertices"].attrs["personal_strength"])
    g_true = f["/scans/truth/global_factors"][:].astype(np.float64)
    e_true = f["/scans/truth/personal_factors"][:].astype(np.float64)
    split = f["/scans/people/split"][:]
    moving = np.where(np.linalg.norm(template, axis=2).max(axis=0) > 1e-4)[0]
    train, test = split == 0, split == 1
    if train.sum() < 2 or test.sum() < 1:
        fail(f"{args.scans}: needs at least 2 training and 1 held-out people")
    people = len(split)
    neutrals = f["/scans/people/neutral"]
    displacements = np.stack([(neutrals[j] - template_neutral).reshape(-1) for j in range(people)])

    # The stored factors must rebuild the stored shapes, or the terms above are not this file's.
    for j in (0, people - 1):
        local, bend = personal_terms(template, template_neutral, neutrals[j].astype(np.float64))
        rebuilt = personal_shapes(template, local, bend, personal, strength, g_true[j], e_true[j])
        worst = float(np.abs(rebuilt - f["/scans/truth/deltas"][j]).max())
        if worst > 1e-4:
            fail(f"{args.scans}: person {j}'s true shapes differ from scan_database.h's form by {worst:.2g} cm")

    observed = g_true * (1.0 + e_true)
    g_error, estimator, lam, g_learnt = learnt_factors(displacements, observed, train, test, g_true)
    shapes_file = h5py.File(args.shapes, "r") if args.shapes else None
    if shapes_file is not None and "/shapes/ours/deltas" not in shapes_file:
        fail(f"{args.shapes}: no /shapes/ours/deltas (write it with facecap eval blendshapes --shapes)")

    rows = {"truth": [], "truth_without_e": [], "form_g_learnt": [], "form_g_one": []}
    if shapes_file is not None:
        rows.update({"ours": [], "ours_scaled": []})
    zero = np.zeros(template.shape[0])
    for j in np.where(test)[0]:
        neutral = neutrals[j].astype(np.float64)
        expressions = f["/scans/people/expressions"][j].astype(np.float64)
        truth = f["/scans/truth/deltas"][j].astype(np.float64)
        local, bend = personal_terms(template, template_neutral, neutral)
        noise_free = personal_shapes(template, local, bend, personal, strength, g_true[j], zero)
        candidates = {
            "truth": truth,
            "truth_without_e": noise_free,
            "form_g_learnt": personal_shapes(template, local, bend, personal, strength, g_learnt[j], zero),
            "form_g_one": personal_shapes(template, local, bend, personal, strength, np.ones_like(zero), zero),
        }
        if shapes_file is not None:
            ours = shapes_file["/shapes/ours/deltas"][j].astype(np.float64)
            flat_ours, flat_truth = ours.reshape(len(ours), -1), truth.reshape(len(truth), -1)
            scale = (flat_ours * flat_truth).sum(1) / np.maximum((flat_ours * flat_ours).sum(1), 1e-30)
            candidates["ours"] = ours
            candidates["ours_scaled"] = ours * scale[:, None, None]
        for name, deltas in candidates.items():
            rows[name].append(reconstruction_errors(neutral, deltas, expressions, moving))
        print(f"person {j}: " + ", ".join(f"{n} {rows[n][-1].mean():.4f}" for n in rows), file=sys.stderr)

    labels = {
        "truth": "True shapes (floor)",
        "truth_without_e": "True shapes without e_ij (best any neutral-only method can do)",
        "form_g_learnt": f"Exact f, h; g learnt from {int(train.sum())} training people ({estimator}, "
                         f"lambda {lam:g}; mean |g error| {g_error:.3f})",
        "form_g_one": "Exact f, h; g = 1",
        "ours": "Ours (generator + tuning)",
        "ours_scaled": "Ours, each shape scaled by its best factor against the truth",
    }
    print(f"Held-out people: {int(test.sum())}, training people: {int(train.sum())}; mean per-vertex "
          "reconstruction error (mm), weights in [0, 1] by bounded least squares")
    print("| Shapes | Held-out error (mm) |\n| --- | --- |")
    for name, values in rows.items():
        print(f"| {labels[name]} | {np.mean(values):.4f} |")
    if args.json:
        out = {name: round(float(np.mean(values)), 4) for name, values in rows.items()}
        out.update({"g_estimator": estimator, "g_lambda": lam, "g_error_mean": round(g_error, 4),
                    "g_spread": round(float(g_true[test].std(axis=0).mean()), 4),
                    "train_people": int(train.sum()), "test_people": int(test.sum()), "units": "mm"})
        print(json.dumps(out))


if __name__ == "__main__":
    main()
