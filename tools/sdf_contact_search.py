"""MuJoCo's SDF contact search between the ball and a man, rebuilt on a sampled distance
field of the man's mesh, against the model's own contacts (docs/reference-game.md, "MuJoCo
against itself"): a prototype for reproducing the model's contacts on our table.

A measuring instrument, not part of the project; needs mujoco 3.3.2, numpy and scipy in a
throwaway venv and a Foosball_CU checkout. Two steps:

    FOOSBALL_CU_SIM=<checkout>/foosball_sim/v2/foosball_sim.xml python tools/sdf_contact_search.py grid --out /tmp/man_sdf.npz
    FOOSBALL_CU_SIM=<checkout>/foosball_sim/v2/foosball_sim.xml python tools/sdf_contact_search.py compare /tmp/man_sdf.npz --poses 300

`grid` samples the signed distance of the man's mesh (as the model's `sdflib` plugin
sees it: the mesh's vertices in the plugin's frame, coincident vertices merged) every
0.05 cm: the exact distance to the nearest of the 96 triangles nearest by centroid, its
sign from the nearest feature's angle-weighted pseudonormal (Baerentzen and Aanaes).
`compare` runs MuJoCo 3.3.2's search (`engine_collision_sdf.c`, `mjc_SDF`:
`sdf_initpoints` Halton starting points in the intersection of the two bounding boxes,
`sdf_iterations` backtracking gradient steps on `A + B + |max(A, B)|`, one step on
`max(A, B)`, a contact where that is at most 0, its normal the midsurface's gradient) on
that grid (trilinear) and the ball's exact sphere, at random poses of the ball by yellow's
centre midfielder (those of tools/mujoco_sensitivity.py's `--contact-poses`), and compares each
pose's contacts with the model's: how many, their mean depth, mean normal and mean place.
With `--model-moved EPS` it compares the model with itself at each pose and with the
ball EPS cm further along x instead (how smoothly the model's contacts move).
"""
import argparse
import os
import time

import mujoco
import numpy as np

from mujoco_sensitivity import midfielder_pair, midfielder_poses


def closest_on_triangles(p, a, b, c):
    # Ericson's closest point on triangle, vectorised over rows
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    bp = p - b; d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    cp = p - c; d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va_ = d3 * d6 - d5 * d4; vb = d5 * d2 - d1 * d6; vc = d1 * d4 - d3 * d2
    denom = 1.0 / np.where(va_ + vb + vc == 0, 1e-30, va_ + vb + vc)
    v = vb * denom; w = vc * denom
    res = a + ab * v[..., None] + ac * w[..., None]
    region = np.zeros(res.shape[:-1], dtype=np.int8)
    # edges and vertices
    m1 = (d1 <= 0) & (d2 <= 0); res[m1] = a[m1]; region[m1] = 1
    m2 = (d3 >= 0) & (d4 <= d3) & ~m1; res[m2] = b[m2]; region[m2] = 2
    m3 = (d6 >= 0) & (d5 <= d6) & ~(m1 | m2); res[m3] = c[m3]; region[m3] = 3
    m4 = (vc <= 0) & (d1 >= 0) & (d3 <= 0) & ~(m1 | m2 | m3)
    t = d1 / np.where(d1 - d3 == 0, 1e-30, d1 - d3); res[m4] = (a + ab * t[..., None])[m4]; region[m4] = 4
    m5 = (vb <= 0) & (d2 >= 0) & (d6 <= 0) & ~(m1 | m2 | m3 | m4)
    t = d2 / np.where(d2 - d6 == 0, 1e-30, d2 - d6); res[m5] = (a + ac * t[..., None])[m5]; region[m5] = 5
    m6 = (va_ <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0) & ~(m1 | m2 | m3 | m4 | m5)
    t = (d4 - d3) / np.where((d4 - d3) + (d5 - d6) == 0, 1e-30, (d4 - d3) + (d5 - d6))
    res[m6] = (b + (c - b) * t[..., None])[m6]; region[m6] = 6
    return res, region


def sdf_man(x):
    """The sampled distance at `x` (the plugin's frame, cm), trilinear, and its gradient."""
    u = (x - lo) / h
    i = np.clip(np.floor(u).astype(int), 0, shape - 2)
    f = np.clip(u - i, 0, 1)
    c = D[i[0]:i[0] + 2, i[1]:i[1] + 2, i[2]:i[2] + 2]
    cx = c[0] * (1 - f[0]) + c[1] * f[0]
    cy = cx[0] * (1 - f[1]) + cx[1] * f[1]
    val = cy[0] * (1 - f[2]) + cy[1] * f[2]
    # gradient of the trilinear interpolant
    gx = ((c[1] - c[0])[0] * (1 - f[1]) + (c[1] - c[0])[1] * f[1])
    gx = (gx[0] * (1 - f[2]) + gx[1] * f[2]) / h
    gy = (cx[1] - cx[0]); gy = (gy[0] * (1 - f[2]) + gy[1] * f[2]) / h
    gz = (cy[1] - cy[0]) / h
    return val, np.array([gx, gy, gz])


def contacts_ours():
    """The search with the ball's sphere as g1 and the man as g2: (depth, world place,
    world normal from the ball to the man) per contact."""
    radius = m.geom_size[ball][0]
    mid = m.geom_dataid[man]
    # the man's true (plugin) frame in the world: geom pose o inverse(mesh pose)
    Rg = d.geom_xmat[man].reshape(3, 3); pg = d.geom_xpos[man]
    Rm = quat_mat(m.mesh_quat[mid]); pm = m.mesh_pos[mid]
    R2 = Rg @ Rm.T; p2 = pg - R2 @ pm                 # world = R2 x + p2
    c = d.geom_xpos[ball]; R1 = d.geom_xmat[ball].reshape(3, 3)
    # aabbs in the sphere's frame
    a2 = m.geom_aabb[man]; corners = []
    for k in range(8):
        v = np.array([a2[0] + (a2[3] if k & 1 else -a2[3]), a2[1] + (a2[4] if k & 2 else -a2[4]), a2[2] + (a2[5] if k & 4 else -a2[5])])
        corners.append(R1.T @ (Rg @ v + pg - c))
    corners = np.array(corners)
    box = np.r_[np.maximum(-radius, corners.min(0)), np.minimum(radius, corners.max(0))]
    if (box[3:] < box[:3]).any():
        return []
    to1 = lambda x: R1.T @ (R2 @ x + p2 - c)          # man-true -> sphere frame
    def A(x):
        y = to1(x); n = np.linalg.norm(y); return n - radius, (R2.T @ R1 @ (y / n))
    def coll(x):
        b, gb = sdf_man(x); a, ga = A(x)
        val = a + b + abs(max(a, b))
        g = ga + gb + (ga if a > b else gb) * (1 if max(a, b) > 0 else -1)
        return val, g
    def inter(x):
        b, gb = sdf_man(x); a, ga = A(x)
        return (b, gb) if b > a else (a, ga)
    def mids(x):
        b, gb = sdf_man(x); a, ga = A(x)
        g = gb / np.linalg.norm(gb) - ga / np.linalg.norm(ga)
        return b - a, g / np.linalg.norm(g)
    def descend(x, f, n):
        dist = 1e10
        for _ in range(n):
            _, gr = f(x); x0 = x.copy(); d0 = f(x0)[0]
            alpha = 2.0; wolfe = -0.1 * alpha * gr @ gr
            while True:
                alpha *= 0.5; wolfe *= 0.5
                x = x0 - alpha * gr; dist = f(x)[0]
                if not (alpha > 1e-4 and dist - d0 > wolfe):
                    break
            if d0 < dist:
                return x, dist
        return x, dist
    out = []
    for j in range(m.opt.sdf_initpoints):
        x1 = box[:3] + (box[3:] - box[:3]) * np.array([halton(j, 2), halton(j, 3), halton(j, 5)])
        x = R2.T @ (c + R1 @ x1 - p2)                  # sphere frame -> man-true
        x, _ = descend(x, coll, m.opt.sdf_iterations)
        x, dist = descend(x, inter, 1)
        if dist > 0:
            continue
        _, gm = mids(x)
        normal = R2 @ (-gm)
        pos = R2 @ x + p2 - normal * dist / 2
        out.append(np.r_[dist, pos, normal])
    return out


def contacts_model():
    """The model's contacts of the pose, as `contacts_ours` gives them."""
    out = []
    for con in d.contact[:d.ncon]:
        s = 1 if con.geom1 == ball else -1   # normal from the ball's side, as ours (g1 = sphere)
        out.append(np.r_[con.dist, con.pos, s * con.frame[:3]])
    return out


def load():
    m = mujoco.MjModel.from_xml_path(os.environ["FOOSBALL_CU_SIM"])
    return m, mujoco.MjData(m)


def grid_main(a):
    from scipy.spatial import cKDTree

    m, _ = load()
    g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "y_mid_guy3")
    mid = m.geom_dataid[g]
    va, nv = m.mesh_vertadr[mid], m.mesh_vertnum[mid]
    fa, nf = m.mesh_faceadr[mid], m.mesh_facenum[mid]
    V = m.mesh_vert[va:va + nv].astype(float)
    F = m.mesh_face[fa:fa + nf]
    Vt = V @ quat_mat(m.mesh_quat[mid]).T + m.mesh_pos[mid]  # the plugin's frame
    key = np.round(Vt / 1e-5).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    F = inv.reshape(-1)[F]
    Vt = Vt[first]
    T = Vt[F]
    N = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    N /= np.linalg.norm(N, axis=1, keepdims=True) + 1e-30
    VN = np.zeros((len(Vt), 3))
    for k in range(3):
        e1, e2 = T[:, (k + 1) % 3] - T[:, k], T[:, (k + 2) % 3] - T[:, k]
        cos = (e1 * e2).sum(1) / (np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1) + 1e-30)
        np.add.at(VN, F[:, k], np.arccos(np.clip(cos, -1, 1))[:, None] * N)
    edges = {}
    for f in range(len(F)):
        for k in range(3):
            e = tuple(sorted((F[f, k], F[f, (k + 1) % 3])))
            edges[e] = edges.get(e, 0) + N[f]
    lo, hi = Vt.min(0) - 0.4, Vt.max(0) + 0.4
    axes = [np.arange(lo[i], hi[i] + a.step, a.step) for i in range(3)]
    P = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    tree, K, D = cKDTree(T.mean(1)), 96, np.empty(len(P))
    start = time.time()
    for s in range(0, len(P), 8000):
        p = P[s:s + 8000]
        _, idx = tree.query(p, k=K)
        pp = np.repeat(p[:, None], K, 1)
        q, region = closest_on_triangles(pp, T[idx, 0], T[idx, 1], T[idx, 2])
        dist = np.linalg.norm(pp - q, axis=-1)
        j = dist.argmin(1)
        r = np.arange(len(p))
        f, reg = idx[r, j], region[r, j]
        nrm = N[f].copy()
        for code, k in ((1, 0), (2, 1), (3, 2)):
            sel = reg == code
            nrm[sel] = VN[F[f[sel], k]]
        for code, (k, l) in ((4, (0, 1)), (5, (0, 2)), (6, (1, 2))):
            sel = np.nonzero(reg == code)[0]
            nrm[sel] = np.array([edges[tuple(sorted((F[f[i], k], F[f[i], l])))] for i in sel]).reshape(-1, 3)
        side = ((p - q[r, j]) * nrm).sum(-1)
        D[s:s + 8000] = np.where(side >= 0, dist[r, j], -dist[r, j])
    shape = [len(x) for x in axes]
    np.savez_compressed(a.out, lo=lo, h=a.step, d=D.reshape(shape).astype(np.float32))
    print(f"{a.out}: grid {shape} at {a.step} cm, {time.time() - start:.0f} s, inside share {(D < 0).mean():.3f}")


def quat_mat(q):
    r = np.zeros(9)
    mujoco.mju_quat2Mat(r, q)
    return r.reshape(3, 3)


def halton(i, base):
    """MuJoCo's mju_Halton: the radical inverse of `i` in `base`."""
    f, r = 1.0 / base, 0.0
    while i > 0:
        r += f * (i % base)
        i //= base
        f /= base
    return r


def compare_main(a):
    global m, d, ball, man, lo, h, D, shape
    m, d = load()
    ball_x = m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "ball_x")]
    ball, man = midfielder_pair(m)
    G = np.load(a.grid)
    lo, h, D = G["lo"], float(G["h"]), G["d"].astype(float)
    shape = np.array(D.shape)
    both, only_model, only_ours = [], 0, 0
    for _ in midfielder_poses(m, d, a.poses):
        t = np.array(contacts_model())
        if a.model_moved:
            # the model against itself, its ball moved along x
            d.qpos[ball_x] += a.model_moved
            mujoco.mj_forward(m, d)
            o = np.array(contacts_model())
        else:
            o = np.array(contacts_ours())
        if len(t) and len(o):
            nt, no = t[:, 4:].mean(0), o[:, 4:].mean(0)
            cos = nt @ no / np.linalg.norm(nt) / np.linalg.norm(no)
            both.append((len(t) - len(o), abs(t[:, 0].mean() - o[:, 0].mean()),
                         np.degrees(np.arccos(np.clip(cos, -1, 1))),
                         np.linalg.norm(t[:, 1:4].mean(0) - o[:, 1:4].mean(0))))
        elif len(t):
            only_model += 1
        elif len(o):
            only_ours += 1
    b = np.array(both)
    q = lambda v: f"median {np.median(v):.3f} [{np.quantile(v, .25):.3f}, {np.quantile(v, .75):.3f}]"
    print(f"{a.poses} poses: touching on both {len(b)}, on the model only {only_model}, here only {only_ours}")
    print("contacts, the model's less ours:", q(b[:, 0]))
    print("mean depth difference (cm):", q(b[:, 1]))
    print("angle between the mean normals (deg):", q(b[:, 2]))
    print("distance between the mean places (cm):", q(b[:, 3]))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("grid", help="sample the man's signed distance field")
    g.add_argument("--out", required=True)
    g.add_argument("--step", type=float, default=0.05, help="grid spacing, cm")
    c = sub.add_parser("compare", help="the search on the grid against the model's contacts")
    c.add_argument("grid")
    c.add_argument("--poses", type=int, default=300)
    c.add_argument("--model-moved", type=float, default=0.0,
                   help="compare the model with itself, its ball moved this far along x (cm), instead")
    a = p.parse_args()
    grid_main(a) if a.cmd == "grid" else compare_main(a)


if __name__ == "__main__":
    main()
