#!/usr/bin/env python3
"""Score 68-point landmarks of real footage against a reference landmarker.

usage: compare_landmarks.py REF.json CANDIDATE [CANDIDATE ...] [--holdout-every N] [--json OUT]

  REF.json   landmarks of an independent detector, as written by the ref_landmarks tools
             ({frames: [{index, faces: [{landmarks: [[x, y] x 68]}]}]}, source pixels)
  CANDIDATE  a CSV of `facecap export landmarks` (source_index, timecode, x_0..x_67,
             y_0..y_67, visible_0..visible_67), a facecap ingest output (frames.h5: dlib's
             landmarks) or another reference JSON

Frames are matched by source frame index. NME is the mean point-to-point distance over the
reference's outer-eye-corner distance (points 36 and 45), averaged over the frames where both
have a face. With --holdout-every N, the candidate's k-th row (k counted over the ingested
frames, as deepfake train's b_holdout_every counts them) is held out when k % N == N - 1,
and held-out and trained frames are reported apart.
Run with Debian's python3 (numpy, h5py).
"""
import csv
import json
import sys

import numpy as np

REGIONS = {'jaw': range(0, 17), 'brows': range(17, 27), 'nose': range(27, 36),
           'eyes': range(36, 48), 'mouth': range(48, 68), 'inner': range(17, 68)}


def load_ref(path):
    with open(path) as f:
        r = json.load(f)
    return {int(fr['index']): (np.array(fr['faces'][0]['landmarks'], np.float64)
                               if fr['faces'] else None) for fr in r['frames']}


def load_candidate(path):
    """{source_index: (row, 68x2 or None)}"""
    if path.endswith('.json'):
        ref = load_ref(path)
        return {i: (k, v) for k, (i, v) in enumerate(sorted(ref.items()))}
    if path.endswith('.csv'):
        out = {}
        with open(path) as f:
            rows = csv.reader(f)
            header = next(rows)
            if header[:2] != ['source_index', 'timecode'] or len(header) != 2 + 3 * 68:
                sys.exit(f'{path}: not a facecap landmarks CSV (header {header[:3]}...)')
            for k, row in enumerate(rows):
                i = int(row[0])
                if row[2] == '':
                    out[i] = (k, None)
                    continue
                v = np.array([float(x) for x in row[2:2 + 136]], np.float64)
                out[i] = (k, np.stack([v[:68], v[68:]], axis=1))
        return out
    import h5py
    with h5py.File(path, 'r') as h:
        idx = h['/frames/source_index'][...].astype(int)
        found = h['/frames/found'][...].astype(bool)
        lm = h['/frames/landmarks'][...].astype(np.float64)
    return {int(i): (k, lm[k] if found[k] else None) for k, i in enumerate(idx)}


def summarize(ref, cand, rows):
    if not rows:
        return None
    R = np.stack([ref[i] for i in rows])
    C = np.stack([cand[i][1] for i in rows])
    iod = np.linalg.norm(R[:, 36] - R[:, 45], axis=1)
    d = np.linalg.norm(R - C, axis=2) / iod[:, None]
    out = {'frames': len(rows), 'nme': round(float(d.mean()), 4),
           'nme_median': round(float(np.median(d.mean(axis=1))), 4),
           'nme_p90': round(float(np.percentile(d.mean(axis=1), 90)), 4)}
    for name, r in REGIONS.items():
        out['nme_' + name] = round(float(d[:, list(r)].mean()), 4)
    return out


def main():
    args = sys.argv[1:]
    holdout, json_out = 0, None
    if '--holdout-every' in args:
        k = args.index('--holdout-every')
        holdout = int(args[k + 1])
        del args[k:k + 2]
    if '--json' in args:
        k = args.index('--json')
        json_out = args[k + 1]
        del args[k:k + 2]
    if len(args) < 2:
        print(__doc__)
        sys.exit(2)
    ref = load_ref(args[0])
    report = []
    for path in args[1:]:
        cand = load_candidate(path)
        both = sorted(i for i in set(ref) & set(cand)
                      if ref[i] is not None and cand[i][1] is not None)
        missing = sum(1 for i in set(ref) & set(cand) if ref[i] is not None and cand[i][1] is None)
        entry = {'candidate': path, 'all': summarize(ref, cand, both),
                 'reference_face_candidate_none': missing}
        if holdout:
            held = [i for i in both if cand[i][0] % holdout == holdout - 1]
            trained = [i for i in both if cand[i][0] % holdout != holdout - 1]
            entry['held_out'] = summarize(ref, cand, held)
            entry['trained'] = summarize(ref, cand, trained)
        report.append(entry)
        a = entry['all']
        line = f"{path}: {a['frames']} frames, NME {a['nme']:.4f} (median {a['nme_median']:.4f}, " \
               f"inner 17-67 {a['nme_inner']:.4f}, jaw {a['nme_jaw']:.4f})" if a else f"{path}: no common frame"
        if holdout and entry['held_out'] and entry['trained']:
            line += f"; held out {entry['held_out']['nme']:.4f}, trained {entry['trained']['nme']:.4f}"
        print(line)
    if json_out:
        with open(json_out, 'w') as f:
            json.dump(report, f, indent=1)


if __name__ == '__main__':
    main()
