#!/usr/bin/env python3
"""What a better object surface would be worth: a reconstructed mesh with its object part made true.

Reads a finished workspace of a synthetic scene (docs/FORMATS.md), as tools/mesh_normal_error.py:
  stages/mesh/mesh.ply                   the mesh the inverse rendering used (model frame)
  stages/evaluate/metrics.json           frame.truth_from_model (the similarity evaluate found)
  stages/ingest/ground_truth/mesh.ply    the true object, with normals

and writes a mesh in the model frame where the vertices within `--tolerance` of the true object
(a fraction of its bounding-box diagonal, 0.02 as evaluate's albedo) are changed:
  normals    each takes the normal of the nearest true vertex (positions and triangles kept);
  positions  each moves onto the nearest true vertex, with its normal (triangles kept);
  swap       the object's triangles are replaced by the whole true object (the ground stays).

Running the rest of the chain on it tells how much of the relighting the object's shading normals,
its vertex positions or its whole surface would give (docs/RESULTS.md, "The whole chain"):

  cp -a WS WS_oracle
  /usr/bin/python3 tools/mesh_oracle.py WS_oracle swap --out /tmp/mesh.ply
  cp /tmp/mesh.ply "$(readlink -f WS_oracle/stages/mesh)/mesh.ply"
  build/bin/pipeline run CONFIG --workspace WS_oracle --from visibility

Not a stage and not for users: a measurement tool. Nearest vertices by brute force in NumPy (the
reconstruction's object vertices are few).
"""
import argparse
import json
import os
import sys

import numpy as np

FACE = np.dtype([('n', 'u1'), ('i', '<i4', 3)])


def read_mesh(path):
    """Positions, normals and triangles of a binary little-endian PLY whose vertices are floats
    (x y z nx ny nz and any others, which are dropped)."""
    raw = open(path, 'rb').read()
    end = raw.find(b'end_header\n')
    if not raw.startswith(b'ply') or end < 0:
        sys.exit(f"{path}: not a PLY file")
    header = raw[:end].decode('ascii', 'replace').splitlines()
    body = raw[end + len(b'end_header\n'):]
    if 'format binary_little_endian 1.0' not in header:
        sys.exit(f"{path}: only binary little-endian PLY is read here")
    counts = {l.split()[1]: int(l.split()[2]) for l in header if l.startswith('element')}
    vertex_props = header[header.index(next(l for l in header if l.startswith('element vertex'))) + 1:]
    vertex_props = [l.split() for l in vertex_props[:next(i for i, l in enumerate(vertex_props) if l.startswith('element'))]]
    props = [w[2] for w in vertex_props]
    if any(w[1] not in ('float', 'float32') for w in vertex_props) or not {'x', 'y', 'z', 'nx', 'ny', 'nz'} <= set(props):
        sys.exit(f"{path}: expected float vertex properties with x y z nx ny nz, found {vertex_props}")
    nv, nf = counts['vertex'], counts['face']
    v = np.frombuffer(body, dtype='<f4', count=nv * len(props)).reshape(nv, len(props)).astype(np.float64)
    v = v[:, [props.index(c) for c in ('x', 'y', 'z', 'nx', 'ny', 'nz')]]
    f = np.frombuffer(body, dtype=FACE, count=nf, offset=nv * 4 * len(props))
    if not (f['n'] == 3).all():
        sys.exit(f"{path}: only triangles are read here")
    return v[:, :3], v[:, 3:], f['i'].astype(np.int64)


def write_mesh(path, p, n, f):
    header = ("ply\nformat binary_little_endian 1.0\ncomment written by tools/mesh_oracle.py\n"
              f"element vertex {len(p)}\n" + "".join(f"property float {c}\n" for c in ('x', 'y', 'z', 'nx', 'ny', 'nz')) +
              f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    faces = np.zeros(len(f), dtype=FACE)
    faces['n'], faces['i'] = 3, f
    tmp = path + '.tmp'
    with open(tmp, 'wb') as out:
        out.write(header.encode('ascii'))
        out.write(np.hstack([p, n]).astype('<f4').tobytes())
        out.write(faces.tobytes())
    os.replace(tmp, path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('workspace')
    ap.add_argument('mode', choices=['normals', 'positions', 'swap'])
    ap.add_argument('--out', required=True, help='the mesh to write (PLY)')
    ap.add_argument('--tolerance', type=float, default=0.02)
    args = ap.parse_args()
    stages = os.path.join(args.workspace, 'stages')
    metrics = os.path.join(stages, 'evaluate/metrics.json')
    if not os.path.isfile(metrics):
        sys.exit(f"{metrics} is missing: run the workspace through evaluate first (pipeline run CONFIG)")
    frame = json.load(open(metrics)).get('frame', {})
    if 'truth_from_model' in frame:
        t = frame['truth_from_model']
        scale, rot, trans = t['scale'], np.array(t['rotation']).reshape(3, 3), np.array(t['translation'])
    else:
        scale, rot, trans = 1.0, np.eye(3), np.zeros(3)
    p, n, f = read_mesh(os.path.join(stages, 'mesh/mesh.ply'))
    q, m, g = read_mesh(os.path.join(stages, 'ingest/ground_truth/mesh.ply'))
    m /= np.maximum(np.linalg.norm(m, axis=1, keepdims=True), 1e-12)
    p_truth = scale * p @ rot.T + trans
    tol = args.tolerance * np.linalg.norm(q.max(0) - q.min(0))
    nearest = np.full(len(p), -1)
    candidates = np.nonzero(np.all((p_truth > q.min(0) - tol) & (p_truth < q.max(0) + tol), axis=1))[0]
    for s in range(0, len(candidates), 500):
        idx = candidates[s:s + 500]
        d2 = ((p_truth[idx][:, None, :] - q[None]) ** 2).sum(-1)
        j = d2.argmin(1)
        ok = d2[np.arange(len(j)), j] <= tol * tol
        nearest[idx[ok]] = j[ok]
    on_object = nearest >= 0
    if not on_object.any():
        sys.exit("no mesh vertex lies within the tolerance of the true object")
    # Truth frame -> model frame: x_model = R^T (x_truth - t) / s; directions R^T d (rows: d @ R).
    if args.mode in ('normals', 'positions'):
        n[on_object] = m[nearest[on_object]] @ rot
        if args.mode == 'positions':
            p[on_object] = ((q[nearest[on_object]] - trans) @ rot) / scale
    else:
        kept = f[~on_object[f].any(1)]
        used = np.unique(kept)
        remap = np.full(len(p), -1)
        remap[used] = np.arange(len(used))
        p = np.vstack([p[used], ((q - trans) @ rot) / scale])
        n = np.vstack([n[used], m @ rot])
        f = np.vstack([remap[kept], g + len(used)])
    write_mesh(args.out, p, n, f)
    print(f"{args.mode}: {on_object.sum()} of the mesh's vertices on the true object; wrote {len(p)} vertices, "
          f"{len(f)} triangles to {args.out}")


if __name__ == '__main__':
    main()
