"""Independent check of a triangle surface for self-intersection (numpy only, no msim code): the
pairs of triangles that share no vertex and intersect, by segment-triangle tests (Moller-Trumbore
restricted to the segment) of every edge of one against the other, both ways, over the candidate
pairs whose boxes overlap (a uniform grid of cell = twice the mean edge length)."""
import numpy as np


def cloth_triangles(n):
    """The N x N cloth grid's triangles (vertex (i, j) has id j N + i): each cell split along its
    (i,j)-(i+1,j+1) diagonal, as msim's self-contact term splits it (any split would do here)."""
    N = int(round(np.sqrt(n)))
    assert N * N == n, f"{n} vertices is not a square cloth"
    i, j = np.meshgrid(np.arange(N - 1), np.arange(N - 1), indexing="xy")
    a = (j * N + i).ravel()
    b, c, d = a + 1, a + N + 1, a + N
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def surface_triangles(cells):
    """The surface of a mesh's cells (an (m, 3) or (m, 4) integer array): its triangles, or a tet
    mesh's boundary faces, those that belong to exactly one tet (msim's self-contact surface)."""
    cells = np.asarray(cells, dtype=np.int64)
    if cells.shape[1] == 3:
        return cells
    faces = np.concatenate([cells[:, [1, 2, 3]], cells[:, [0, 2, 3]], cells[:, [0, 1, 3]], cells[:, [0, 1, 2]]])
    key = np.sort(faces, axis=1)
    _, first, count = np.unique(key, axis=0, return_index=True, return_counts=True)
    return faces[first[count == 1]]


def candidate_pairs(x, tris):
    lo, hi = x[tris].min(axis=1), x[tris].max(axis=1)
    edge = np.linalg.norm(x[tris[:, 1]] - x[tris[:, 0]], axis=1).mean()
    cell = max(2 * edge, 1e-12)
    ilo, ihi = np.floor(lo / cell).astype(np.int64), np.floor(hi / cell).astype(np.int64)
    buckets = {}
    for t in range(len(tris)):
        for a in range(ilo[t, 0], ihi[t, 0] + 1):
            for b in range(ilo[t, 1], ihi[t, 1] + 1):
                for c in range(ilo[t, 2], ihi[t, 2] + 1):
                    buckets.setdefault((a, b, c), []).append(t)
    pairs = set()
    for ts in buckets.values():
        for p in range(len(ts)):
            for q in range(p + 1, len(ts)):
                pairs.add((ts[p], ts[q]) if ts[p] < ts[q] else (ts[q], ts[p]))
    if not pairs:
        return np.zeros((0, 2), dtype=np.int64)
    P = np.array(sorted(pairs), dtype=np.int64)
    overlap = np.all((lo[P[:, 0]] <= hi[P[:, 1]]) & (lo[P[:, 1]] <= hi[P[:, 0]]), axis=1)
    P = P[overlap]
    shared = (tris[P[:, 0]][:, :, None] == tris[P[:, 1]][:, None, :]).any(axis=(1, 2))
    return P[~shared]


def segments_hit(p, q, a, b, c, eps=1e-14):
    """segment p-q crosses triangle abc (arrays of shape (m, 3))"""
    d, e1, e2 = q - p, b - a, c - a
    h = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, h)
    ok = np.abs(det) > eps * np.linalg.norm(d, axis=1) * np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
    f = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = p - a
    u = f * np.einsum("ij,ij->i", s, h)
    qq = np.cross(s, e1)
    v = f * np.einsum("ij,ij->i", d, qq)
    t = f * np.einsum("ij,ij->i", e2, qq)
    return ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)


def intersecting_pairs(x, tris):
    """the number of vertex-disjoint triangle pairs of the surface (x: (n, 3), tris: (m, 3)) that
    intersect"""
    P = candidate_pairs(x, tris)
    if len(P) == 0:
        return 0
    hit = np.zeros(len(P), dtype=bool)
    for s, o in ((0, 1), (1, 0)):
        A, B = tris[P[:, s]], tris[P[:, o]]
        for k in range(3):
            p, q = x[A[:, k]], x[A[:, (k + 1) % 3]]
            hit |= segments_hit(p, q, x[B[:, 0]], x[B[:, 1]], x[B[:, 2]])
    return int(hit.sum())


if __name__ == "__main__":
    # two triangles crossing, and two apart
    x = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.2, 0.2, -1], [0.2, 0.2, 1], [1, 1, 0.5]], float)
    assert intersecting_pairs(x, np.array([[0, 1, 2], [3, 4, 5]])) == 1
    x[3:, 0] += 5
    assert intersecting_pairs(x, np.array([[0, 1, 2], [3, 4, 5]])) == 0
    # two tets sharing a face: 6 boundary faces of the 8, the shared one left out
    s = surface_triangles([[0, 1, 2, 3], [1, 2, 3, 4]])
    assert len(s) == 6 and not any(sorted(f) == [1, 2, 3] for f in s.tolist())
    print("ok")
