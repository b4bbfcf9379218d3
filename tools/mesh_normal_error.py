#!/usr/bin/env python3
"""How far a reconstructed mesh's vertex normals are from the true object's.

Reads a finished workspace of a synthetic scene (docs/FORMATS.md):
  stages/mesh/mesh.ply                      the mesh the inverse rendering used (model frame)
  stages/evaluate/metrics.json              frame.truth_from_model (the similarity evaluate found)
  stages/ingest/ground_truth/mesh.ply       the true object, with normals

Each mesh vertex is mapped into the truth's frame (normals rotated); vertices
within `--tolerance` (a fraction of the true object's bounding-box diagonal,
default 0.02 as evaluate's albedo) of a true object vertex are the object's,
and their normal is compared with the nearest true vertex's. Prints the count
and the median, mean and 90th percentile of the angle in degrees. The nearest
vertex is a brute-force search in NumPy (the object's vertices are few); the
true mesh should be dense next to the reconstruction's edge length.

Usage: /usr/bin/python3 tools/mesh_normal_error.py WORKSPACE [--tolerance 0.02]
"""
import argparse
import json
import os
import sys

import numpy as np

PLY_TYPES = {'float': '<f4', 'float32': '<f4', 'double': '<f8', 'uchar': 'u1', 'uint8': 'u1',
             'int': '<i4', 'int32': '<i4', 'uint': '<u4', 'uint32': '<u4'}


def read_vertices(path):
    """Vertex positions and normals of a binary little-endian PLY."""
    with open(path, 'rb') as f:
        header = []
        while True:
            line = f.readline()
            if not line:
                sys.exit(f"{path}: no end_header; not a PLY file")
            line = line.decode('ascii', 'replace').strip()
            header.append(line)
            if line == 'end_header':
                break
        body = f.read()
    if 'format binary_little_endian 1.0' not in header:
        sys.exit(f"{path}: only binary little-endian PLY is read here")
    count, props, in_vertex = 0, [], False
    for line in header:
        words = line.split()
        if words[0] == 'element':
            in_vertex = words[1] == 'vertex'
            if in_vertex:
                count = int(words[2])
        elif words[0] == 'property' and in_vertex:
            if words[1] == 'list' or words[1] not in PLY_TYPES:
                sys.exit(f"{path}: unexpected vertex property '{line}'")
            props.append((words[2], PLY_TYPES[words[1]]))
    v = np.frombuffer(body, dtype=np.dtype(props), count=count)
    for name in ('nx', 'ny', 'nz'):
        if name not in v.dtype.names:
            sys.exit(f"{path}: the vertices have no normals")
    p = np.stack([v['x'], v['y'], v['z']], 1).astype(np.float64)
    n = np.stack([v['nx'], v['ny'], v['nz']], 1).astype(np.float64)
    return p, n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('workspace')
    ap.add_argument('--tolerance', type=float, default=0.02)
    args = ap.parse_args()
    ws = args.workspace
    paths = {k: os.path.join(ws, 'stages', p) for k, p in
             {'mesh': 'mesh/mesh.ply', 'metrics': 'evaluate/metrics.json',
              'truth': 'ingest/ground_truth/mesh.ply'}.items()}
    for key, path in paths.items():
        if not os.path.isfile(path):
            sys.exit(f"{path} is missing: run the workspace through evaluate first (pipeline run CONFIG)")
    frame = json.load(open(paths['metrics'])).get('frame', {})
    if 'truth_from_model' in frame:
        t = frame['truth_from_model']
        scale, rot, trans = t['scale'], np.array(t['rotation']).reshape(3, 3), np.array(t['translation'])
    elif frame.get('method') == 'identity':
        scale, rot, trans = 1.0, np.eye(3), np.zeros(3)
    else:
        sys.exit(f"{paths['metrics']}: no truth_from_model; the model's frame is not related to the truth")
    p, n = read_vertices(paths['mesh'])
    q, m = read_vertices(paths['truth'])
    p = scale * p @ rot.T + trans
    n = n @ rot.T
    tol = args.tolerance * np.linalg.norm(q.max(0) - q.min(0))
    near = np.all((p > q.min(0) - tol) & (p < q.max(0) + tol), axis=1)
    idx = np.nonzero(near)[0]
    angles = []
    for s in range(0, len(idx), 1000):
        chunk = p[idx[s:s + 1000]]
        d2 = ((chunk[:, None, :] - q[None, :, :]) ** 2).sum(-1)
        j = d2.argmin(1)
        ok = d2[np.arange(len(j)), j] <= tol * tol
        cos = (n[idx[s:s + 1000]][ok] * m[j[ok]]).sum(1)
        angles.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    a = np.concatenate(angles) if angles else np.zeros(0)
    if a.size == 0:
        sys.exit("no mesh vertex lies within the tolerance of the true object")
    print(f"{a.size} of {len(p)} mesh vertices on the true object: normal error median {np.median(a):.2f} deg, "
          f"mean {a.mean():.2f}, 90th percentile {np.percentile(a, 90):.2f}")


if __name__ == '__main__':
    main()
