#!/usr/bin/env python3
"""Independent estimate of a disk map's element areas (issue 18 part 2), for bench_disk.sh.

evalmap.py has no disk domain, so this is a second implementation written apart from the C++ one:
every face is cut into n^2 equal sub-triangles, each sub-triangle's 3D area goes to the element its
centroid falls in, found by the inverse of Shirley & Chiu's concentric map (the disk's K x K
elements are the square's cells carried by that map). The error is the sub-triangle binning only,
which shrinks as 1/n. Vertices the map inserted are placed from its authalic_inserted_vertices
metadata ("p0 p1 w;..."), as flatten wrote them.

usage: disk_elements.py SURFACE DISK_MAP [--k 32] [--n 8]   -> prints JSON {element_cv, flips, face_ln_area_abs_mean}
"""
import argparse, json
import numpy as np
import nibabel as nib


def disk_to_unit_square(P):
    x, y = P[:, 0], P[:, 1]
    r, q = np.hypot(x, y), np.pi / 4
    phi = np.arctan2(y, x)
    phi = np.where(phi < -q, phi + 2 * np.pi, phi)
    a = np.select([phi < q, phi < 3 * q, phi < 5 * q], [r, -r * (phi / q - 2), -r], r * (phi / q - 6))
    b = np.select([phi < q, phi < 3 * q, phi < 5 * q], [r * phi / q, r, -r * (phi / q - 4)], -r)
    return np.c_[(a + 1) / 2, (b + 1) / 2]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('surface'); ap.add_argument('map')
    ap.add_argument('--k', type=int, default=32); ap.add_argument('--n', type=int, default=8)
    a = ap.parse_args()
    g = nib.load(a.map)
    D = g.darrays[0].data.astype(float)[:, :2]
    F = g.darrays[1].data.astype(int)
    V = nib.load(a.surface).darrays[0].data.astype(float)
    if len(D) > len(V):
        rows = [t.split() for t in dict(g.meta.items())['authalic_inserted_vertices'].split(';') if t.strip()]
        n0 = len(V)
        V = np.r_[V, np.zeros((len(D) - len(V), 3))]
        for i, (p0, p1, w) in enumerate(rows):
            V[n0 + i] = (1 - float(w)) * V[int(p0)] + float(w) * V[int(p1)]
    R = D / np.abs(np.hypot(D[:, 0], D[:, 1])).max()
    A3 = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    e1, e2 = R[F[:, 1]] - R[F[:, 0]], R[F[:, 2]] - R[F[:, 0]]
    a2 = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    ok = a2 > 0
    ratio = np.log((a2[ok] / a2[ok].sum()) / (A3[ok] / A3[ok].sum()))
    n, K = a.n, a.k
    # Centroids of the n^2 sub-triangles in barycentric coordinates (upward and downward ones).
    up = [((i + 1 / 3) / n, (j + 1 / 3) / n) for i in range(n) for j in range(n - i)]
    down = [((i + 2 / 3) / n, (j + 2 / 3) / n) for i in range(n) for j in range(n - i - 1)]
    cells = np.zeros(K * K)
    for (u, w) in up + down:
        S = disk_to_unit_square((1 - u - w) * R[F[:, 0]] + u * R[F[:, 1]] + w * R[F[:, 2]])
        c = np.clip((S[:, 1] * K).astype(int), 0, K - 1) * K + np.clip((S[:, 0] * K).astype(int), 0, K - 1)
        cells += np.bincount(c, A3 / (n * n), K * K)
    print(json.dumps({'element_cv': float(cells.std() / cells.mean()), 'flips': int((~ok).sum()),
                      'face_ln_area_abs_mean': float(np.abs(ratio).mean()), 'faces': int(len(F)), 'subdivision': n}))


if __name__ == '__main__':
    main()
