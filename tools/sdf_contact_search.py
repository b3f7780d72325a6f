"""The man's distance field as the paper code's model has it, and MuJoCo's SDF contact
search on it against the model's own contacts (docs/reference-game.md, "The model's
contacts on our table").

A measuring instrument, not part of the project; needs mujoco 3.3.2 and numpy in a
throwaway venv and a Foosball_CU checkout. Three steps:

    FOOSBALL_CU_SIM=<checkout>/foosball_sim/v2/foosball_sim.xml python tools/sdf_contact_search.py grid
    FOOSBALL_CU_SIM=<checkout>/foosball_sim/v2/foosball_sim.xml python tools/sdf_contact_search.py compare --poses 300
    FOOSBALL_CU_SIM=<checkout>/foosball_sim/v2/foosball_sim.xml python tools/sdf_contact_search.py fixture --poses 120

`grid` samples the man's signed distance and its gradient where the model's `sdflib`
plugin computes them (its own functions, called through MuJoCo's plugin table: the
octree the plugin builds from the mesh, signs and all) every `--step` cm over the
plugin's box (the mesh's box and 10 % of its largest side around it), and writes the
field the table ships, `crates/env/data/man_sdf.bin` (format in
`crates/env/src/man_field.rs`): with it the pose of the field's frame in a man's frame
(ours: the rod's frame at the man's x) and the corners of the man's bounding box (the
model's `geom_aabb`) in the field's frame. `compare` runs MuJoCo 3.3.2's search
(`engine_collision_sdf.c`, `mjc_SDF`: `sdf_initpoints` Halton starting points in the
intersection of the two bounding boxes, `sdf_iterations` backtracking gradient steps on
`A + B + |max(A, B)|`, one on `max(A, B)`, a contact where that is at most 0, its normal
the midsurface's) on that field (value and gradient trilinear) and the ball's exact
sphere, at random poses of the ball by yellow's centre midfielder (those of
tools/mujoco_sensitivity.py's `--contact-poses`), and compares each pose's contacts with
the model's: how many, their mean depth, mean normal and mean place. With
`--model-moved EPS` it compares the model with itself at each pose and with the ball EPS
cm further along x instead (how smoothly the model's contacts move). `fixture` writes the
model's contacts at such poses for the table's test (`tests/data/sdf_contacts.json`).
"""
import argparse
import ctypes
import json
import os
import struct

import mujoco
import numpy as np

from mujoco_sensitivity import midfielder_pair, midfielder_poses

FIELD = "crates/env/data/man_sdf.bin"
MAGIC = b"FOOSSDF1"
OCTREE = "crates/env/data/man_octree.bin"
OCTREE_MAGIC = b"FOOSOCT1"
LEAF = 1 << 31  # an octree node that is a leaf: the low bits index its coefficients
DIST_UNIT = 2e-4  # cm per count of the stored distances
GRAD_UNIT = 1.0 / 32000.0  # per count of the stored gradients (unit vectors, a little over 1 where rounded)
MID_ROD = (0.0, -7.5, 7.75)  # yellow's midfield axis at x = 0, world, cm


def quat_mat(q):
    r = np.zeros(9)
    mujoco.mju_quat2Mat(r, q)
    return r.reshape(3, 3)


def mat_quat(r):
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, r.reshape(-1))
    return q


def halton(i, base):
    """MuJoCo's mju_Halton: the radical inverse of `i` in `base`."""
    f, r = 1.0 / base, 0.0
    while i > 0:
        r += f * (i % base)
        i //= base
        f /= base
    return r


def load():
    m = mujoco.MjModel.from_xml_path(os.environ["FOOSBALL_CU_SIM"])
    return m, mujoco.MjData(m)


def plugin_functions(m, d, geom):
    """The model's SDF plugin's distance and gradient for `geom`, as Python functions of a
    point in the plugin's frame (cm)."""
    lib = ctypes.CDLL(os.path.join(os.path.dirname(mujoco.__file__), f"libmujoco.so.{mujoco.__version__}"))
    lib.mjp_getPluginAtSlot.restype = ctypes.c_void_p
    instance = int(m.geom_plugin[geom])
    plugin = lib.mjp_getPluginAtSlot(int(m.plugin[instance]))
    vec = ctypes.POINTER(ctypes.c_double)
    # mjpPlugin's sdf_distance and sdf_gradient (mjplugin.h, x86-64 offsets 112 and 120)
    dist = ctypes.CFUNCTYPE(ctypes.c_double, vec, ctypes.c_void_p, ctypes.c_int)(
        ctypes.c_void_p.from_address(plugin + 112).value)
    grad = ctypes.CFUNCTYPE(None, vec, vec, ctypes.c_void_p, ctypes.c_int)(
        ctypes.c_void_p.from_address(plugin + 120).value)
    data, p, g = ctypes.c_void_p(d._address), (ctypes.c_double * 3)(), (ctypes.c_double * 3)()

    def sample(x):
        p[:] = x
        grad(g, p, data, instance)
        return dist(p, data, instance), np.array(g[:])
    return sample


def field_frame(m, d, geom):
    """The plugin's frame in the world: `world = R x + t` (MuJoCo's `undoTransformation`)."""
    mesh = m.geom_dataid[geom]
    r = d.geom_xmat[geom].reshape(3, 3) @ quat_mat(m.mesh_quat[mesh]).T
    return r, d.geom_xpos[geom] - r @ m.mesh_pos[mesh]


def man_geometry(m, d, man):
    """The plugin's mesh box (its frame, cm), the field's frame in our man frame (the rod's
    frame moved to the man's x: yellow's axes the world's, black's turned half a turn about
    z; the same for every man) as a rotation and translation, and the corners of the man's
    bounding box (the model's `geom_aabb`) in the field's frame."""
    mesh = m.geom_dataid[man]
    va, nv = m.mesh_vertadr[mesh], m.mesh_vertnum[mesh]
    # the plugin's vertices are floats (sdflib's glm::vec3)
    verts = (m.mesh_vert[va:va + nv].astype(float) @ quat_mat(m.mesh_quat[mesh]).T
             + m.mesh_pos[mesh]).astype(np.float32).astype(float)

    def in_man_frame(g):
        rod_joint = [j for j in range(m.njnt) if m.jnt_bodyid[j] == m.body_parentid[m.geom_bodyid[g]]][0]
        turned = np.diag([1.0, 1.0, 1.0]) if d.xaxis[rod_joint][0] > 0 else np.diag([-1.0, -1.0, 1.0])
        origin = np.r_[d.xpos[m.geom_bodyid[g]][0], d.xanchor[rod_joint][1:]]
        rg, tg = field_frame(m, d, g)
        return turned.T @ rg, turned.T @ (tg - origin)
    r, t = in_man_frame(man)
    for g in range(m.ngeom):
        if m.geom_plugin[g] >= 0 and m.geom_dataid[g] == mesh:
            rg, tg = in_man_frame(g)
            assert np.abs(rg - r).max() < 1e-6 and np.abs(tg - t).max() < 1e-4, (g, tg, t)
    aabb = m.geom_aabb[man]
    rm, pm = quat_mat(m.mesh_quat[mesh]), m.mesh_pos[mesh]
    corners = [rm @ np.array([aabb[k] + (aabb[k + 3] if c >> k & 1 else -aabb[k + 3]) for k in range(3)]) + pm
               for c in range(8)]  # the geom's box corners, in the plugin's frame
    return (verts.min(0), verts.max(0)), (r, t), corners


def write_frame(f, r, t, corners):
    f.write(struct.pack("<7f", *t, *mat_quat(r)[[1, 2, 3, 0]]))  # x y z w
    f.write(struct.pack("<24f", *np.ravel(corners)))


def grid_main(a):
    m, d = load()
    mujoco.mj_forward(m, d)
    _, man = midfielder_pair(m)
    (lo, hi), (r, t), corners = man_geometry(m, d, man)
    margin = 0.1 * (hi - lo).max()  # sdflib.cc: box.addMargin(0.1 * largest side)
    lo, hi = lo - margin, hi + margin
    # inside the plugin's box (its gradient outside is a float finite difference: noise)
    n = np.floor((hi - lo) / a.step - 1e-4).astype(int) + 1
    sample = plugin_functions(m, d, man)
    axes = [lo[i] + a.step * np.arange(n[i]) for i in range(3)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    values = np.array([np.r_[sample(p)] for p in points])
    dist = np.round(values[:, 0] / DIST_UNIT)
    grad = np.round(values[:, 1:] / GRAD_UNIT)
    assert np.abs(dist).max() < 32767 and np.abs(grad).max() <= 32767, (np.abs(values).max(0))
    stored = np.c_[dist, grad].astype("<i2")
    with open(a.out, "wb") as f:
        f.write(MAGIC)
        f.write(struct.pack("<3I", *n))
        f.write(struct.pack("<5f", *lo, a.step, DIST_UNIT))
        write_frame(f, r, t, corners)
        f.write(stored.tobytes())
    print(f"{a.out}: {n.tolist()} points every {a.step} cm from {np.round(lo, 4).tolist()}, "
          f"inside share {(values[:, 0] < 0).mean():.3f}, {os.path.getsize(a.out)} bytes")


def octree_main(a):
    """The plugin's octree itself: sdflib's `OctreeSdf(mesh, box, 8, 3, 1e-3, CONTINUITY)`
    on the mesh's box padded by a tenth of its largest side and made a cube, 8 cells a side
    at depth 3, leaves down to depth 8, each leaf's distance a tricubic polynomial of the
    point's place in the leaf. Each leaf is found by fitting a general tricubic (64
    coefficients) to the plugin's distance at 125 points of a cell, from the depth-3 cells
    down: a cell whose fit is exact to float rounding is a leaf, one whose fit is not is
    split in eight. The plugin's gradient is the leaf polynomial's, normalised."""
    m, d = load()
    mujoco.mj_forward(m, d)
    _, man = midfielder_pair(m)
    (lo, hi), (r, t), corners = man_geometry(m, d, man)
    margin = 0.1 * (hi - lo).max()
    lo, hi = lo - margin, hi + margin
    side = (hi - lo).max()
    cube = (lo + hi) / 2 - side / 2
    start, depth_max = 8, 8
    sample = plugin_functions(m, d, man)
    fr = np.array([0.03, 0.26, 0.5, 0.74, 0.97])
    at = np.array([(x, y, z) for x in fr for y in fr for z in fr])
    basis = np.array([[p[0] ** i * p[1] ** j * p[2] ** k for k in range(4) for j in range(4) for i in range(4)]
                      for p in at])
    fit = np.linalg.pinv(basis)
    nodes, leaves, worst = [0] * start ** 3, [], 0.0

    def visit(slot, depth, corner):
        nonlocal worst
        size = side / 2 ** depth
        y = np.array([sample(corner + size * p)[0] for p in at])
        c = fit @ y
        residual = np.abs(basis @ c - y).max()
        if residual < 3e-6 * max(1.0, np.abs(y).max()) or depth == depth_max:
            worst = max(worst, residual)
            nodes[slot] = LEAF | len(leaves)
            leaves.append(c)
            return
        first = len(nodes)
        nodes[slot] = first
        nodes.extend([0] * 8)
        for child in range(8):
            bits = np.array([child & 1, child >> 1 & 1, child >> 2 & 1])
            visit(first + child, depth + 1, corner + bits * size / 2)

    for z in range(start):
        for y in range(start):
            for x in range(start):
                visit((z * start + y) * start + x, 3, cube + np.array([x, y, z]) * side / start)
    with open(a.out, "wb") as f:
        f.write(OCTREE_MAGIC)
        f.write(struct.pack("<2I", start, depth_max))
        f.write(struct.pack("<4f", *cube, side))
        write_frame(f, r, t, corners)
        f.write(struct.pack("<I", len(nodes)))
        f.write(np.array(nodes, dtype="<u4").tobytes())
        f.write(struct.pack("<I", len(leaves)))
        f.write(np.array(leaves, dtype="<f4").tobytes())
    print(f"{a.out}: cube {np.round(cube, 5).tolist()} side {side:.5f}, {len(nodes)} nodes, {len(leaves)} leaves "
          f"(worst fit {worst:.2e} cm), {os.path.getsize(a.out)} bytes")


def read_field(path):
    raw = open(path, "rb").read()
    assert raw[:8] == MAGIC, f"{path}: not a field"
    n = np.array(struct.unpack_from("<3I", raw, 8))
    lo, h, unit = np.array(struct.unpack_from("<3f", raw, 20)), *struct.unpack_from("<2f", raw, 32)
    body = np.frombuffer(raw, "<i2", offset=40 + 28 + 96).reshape(*n, 4).astype(float)
    return lo, h, body[..., 0] * unit, body[..., 1:] * GRAD_UNIT


def field_at(x):
    """The stored field at `x` (the plugin's frame, cm): trilinear value and gradient; off
    the grid, the value at its projection on the grid plus the distance to it (the
    plugin's `boxProjection`)."""
    top = lo + h * (np.array(D.shape) - 1)
    out = np.linalg.norm(np.maximum(lo - x, 0) + np.maximum(x - top, 0))
    x = np.clip(x, lo, top)
    u = (x - lo) / h
    i = np.clip(np.floor(u).astype(int), 0, np.array(D.shape) - 2)
    f = u - i
    w = np.array([[1 - f[k], f[k]] for k in range(3)])
    weights = w[0][:, None, None] * w[1][None, :, None] * w[2][None, None, :]
    cell = (slice(i[0], i[0] + 2), slice(i[1], i[1] + 2), slice(i[2], i[2] + 2))
    return (weights * D[cell]).sum() + out, (weights[..., None] * G[cell]).sum((0, 1, 2))


def contacts_ours():
    """The search with the ball's sphere as g1 and the man as g2: (depth, world place,
    world normal from the ball to the man) per contact."""
    radius = m.geom_size[ball][0]
    r2, p2 = field_frame(m, d, man)                  # world = r2 x + p2
    c = d.geom_xpos[ball]; r1 = d.geom_xmat[ball].reshape(3, 3)
    a2, rg, pg = m.geom_aabb[man], d.geom_xmat[man].reshape(3, 3), d.geom_xpos[man]
    corners = np.array([r1.T @ (rg @ np.array([a2[k] + (a2[k + 3] if j >> k & 1 else -a2[k + 3]) for k in range(3)]) + pg - c)
                        for j in range(8)])
    box = np.r_[np.maximum(-radius, corners.min(0)), np.minimum(radius, corners.max(0))]
    if (box[3:] < box[:3]).any():
        return []

    def sphere(x):
        y = r1.T @ (r2 @ x + p2 - c); n = np.linalg.norm(y)
        return n - radius, r2.T @ r1 @ (y / n)

    def collision(x):
        a, ga = field_at(x); b, gb = sphere(x)
        return a + b + abs(max(a, b)), ga + gb + (ga if a > b else gb) * (1 if max(a, b) > 0 else -1)

    def intersection(x):
        a, ga = field_at(x); b, gb = sphere(x)
        return (a, ga) if a > b else (b, gb)

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

    out, seen = [], []
    for j in range(m.opt.sdf_initpoints):
        x1 = box[:3] + (box[3:] - box[:3]) * np.array([halton(j, 2), halton(j, 3), halton(j, 5)])
        x = r2.T @ (c + r1 @ x1 - p2)                  # sphere frame -> the field's
        x, _ = descend(x, collision, m.opt.sdf_iterations)
        x, dist = descend(x, intersection, 1)
        if dist > 0 or any(np.linalg.norm(x - s) < mujoco.mjMINVAL for s in seen):
            continue
        seen.append(x)
        ga, gb = field_at(x)[1], sphere(x)[1]
        g = ga / np.linalg.norm(ga) - gb / np.linalg.norm(gb)
        normal = r2 @ (-g / np.linalg.norm(g))
        out.append(np.r_[dist, r2 @ x + p2 - normal * dist / 2, normal])
    return out


def contacts_model():
    """The model's contacts of the pose, as `contacts_ours` gives them."""
    out = []
    for con in d.contact[:d.ncon]:
        s = 1 if con.geom1 == ball else -1   # normal from the ball's side, as ours (g1 = sphere)
        out.append(np.r_[con.dist, con.pos, s * con.frame[:3]])
    return out


def compare_main(a):
    global m, d, ball, man, lo, h, D, G
    m, d = load()
    ball_x = m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "ball_x")]
    ball, man = midfielder_pair(m)
    lo, h, D, G = read_field(a.field)
    both, only_model, only_ours, stray = [], 0, 0, 0
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
            # a contact of ours more than 0.5 cm from every one of the model's
            stray += any(np.linalg.norm(t[:, 1:4] - p, axis=1).min() > 0.5 for p in o[:, 1:4])
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
    print(f"poses touching on both with a contact here 0.5 cm or more from all the model's: {stray}")
    print("contacts, the model's less ours:", q(b[:, 0]))
    print("mean depth difference (cm):", q(b[:, 1]))
    print("angle between the mean normals (deg):", q(b[:, 2]))
    print("distance between the mean places (cm):", q(b[:, 3]))


def fixture_main(a):
    """The model's contacts at `a.poses` poses: the rod's turn, the ball's centre (world,
    cm) and each contact's depth, place and normal from the man to the ball (world)."""
    global m, d, ball, man
    m, d = load()
    ball, man = midfielder_pair(m)
    turn = m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "y_mid_rotation")]
    poses = []
    for _ in midfielder_poses(m, d, a.poses):
        contacts = [{"dist": round(float(c[0]), 6), "point": np.round(c[1:4], 6).tolist(),
                     "normal": np.round(-c[4:], 6).tolist()} for c in contacts_model()]
        poses.append({"turn": round(float(d.qpos[turn]), 9), "ball": np.round(d.geom_xpos[ball], 6).tolist(),
                      "contacts": contacts})
    doc = {"what": "the paper code's MuJoCo model's contacts between the ball and yellow's centre "
                   "midfielder (rod axis at x = 0, y = -7.5, z = 7.75, slide 0) at random poses, "
                   "only that pair colliding; made by tools/sdf_contact_search.py fixture",
           "mujoco": mujoco.__version__, "initpoints": int(m.opt.sdf_initpoints),
           "iterations": int(m.opt.sdf_iterations), "radius": float(m.geom_size[ball][0]), "poses": poses}
    with open(a.out, "w") as f:
        json.dump(doc, f, indent=None, separators=(",", ":"))
        f.write("\n")
    print(f"{a.out}: {len(poses)} poses, {sum(1 for p in poses if p['contacts'])} touching")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("grid", help="sample the model's own field of the man")
    g.add_argument("--out", default=FIELD)
    g.add_argument("--step", type=float, default=0.1, help="grid spacing, cm")
    c = sub.add_parser("compare", help="the search on the field against the model's contacts")
    c.add_argument("--field", default=FIELD)
    c.add_argument("--poses", type=int, default=300)
    c.add_argument("--model-moved", type=float, default=0.0,
                   help="compare the model with itself, its ball moved this far along x (cm), instead")
    o = sub.add_parser("octree", help="read the model's own octree of the man off its plugin")
    o.add_argument("--out", default=OCTREE)
    f = sub.add_parser("fixture", help="the model's contacts at random poses, for the table's test")
    f.add_argument("--poses", type=int, default=120)
    f.add_argument("--out", default="tests/data/sdf_contacts.json")
    a = p.parse_args()
    {"grid": grid_main, "octree": octree_main, "compare": compare_main, "fixture": fixture_main}[a.cmd](a)


if __name__ == "__main__":
    main()
