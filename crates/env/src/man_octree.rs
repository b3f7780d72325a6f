//! The man's signed distance field exactly as the reference model's `sdflib` plugin holds
//! it: sdflib's octree (`OctreeSdf(mesh, box, 8, 3, 1e-3, CONTINUITY)`), read off the
//! plugin by `tools/sdf_contact_search.py octree` and shipped as data
//! (`crates/env/data/man_octree.bin`; `crates/env/data/README.md`).
//!
//! The octree spans a cube (the mesh's box padded by a tenth of its largest side, made a
//! cube about its centre), split into 8 × 8 × 8 cells, each split in eight again down to
//! depth 8 where the field needs it. In a leaf of side `s` whose low corner is `c`, the
//! distance is the tricubic `Σ a_ijk u^i v^j w^k` of `(u, v, w) = (p - c) / s`, and the
//! plugin's gradient is that polynomial's gradient, normalised. A point is found in its
//! leaf as the plugin finds it: the depth-3 cell holding it, then at each depth the child
//! on the side of each half its place in the cell falls on (the upper half from 0.5 on).
//!
//! The file: the magic `FOOSOCT1`; the cells per side at depth 3 and the deepest depth
//! (two `u32`); the cube's low corner (three `f32`, cm) and side (`f32`, cm); the pose of
//! the field's frame in a man's frame and the man's box corners, as in
//! [`crate::man_field`]'s file; the node count (`u32`) and the nodes (`u32` each; the
//! first `8³` the depth-3 cells, x fastest): a leaf has the top bit set and its
//! coefficients' index in the low bits, any other node is the index of its first child
//! of eight (child `x + 2y + 4z` for the upper halves `x`, `y`, `z`); the leaf count
//! (`u32`) and per leaf 64 `f32` coefficients `a_ijk`, `i` fastest. Little endian.

use rapier3d::glamx::DVec3;

/// The file's magic.
pub const MAGIC: &[u8; 8] = b"FOOSOCT1";
const LEAF: u32 = 1 << 31;

/// The plugin's octree of the man's distance, in the field's frame (cm).
#[derive(Debug, Clone, PartialEq)]
pub struct Octree {
    /// The cube's low corner, cm.
    low: DVec3,
    /// The cube's side, cm.
    side: f64,
    /// Cells per side at the first depth.
    cells: usize,
    /// Their side, `side / cells` (cm).
    cell: f64,
    nodes: Vec<u32>,
    coefficients: Vec<[f32; 64]>,
    /// Per node, a value the field is above everywhere in its cell (cm): a leaf's
    /// smallest Bernstein coefficient, an inner node's children's least.
    floors: Vec<f64>,
}

/// The leaf a walk last ended in and the point's cell there, so that the next point of
/// the same leaf skips the walk (a search's points cluster): the answer stays the walk's,
/// bit for bit ([`Octree::leaf`]). (Remembering the last three or four leaves as well
/// was measured slower: the checks cost more than the walks they spare.)
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LastLeaf(Option<KnownLeaf>);

#[derive(Debug, Clone, Copy, PartialEq)]
struct KnownLeaf {
    /// The leaf's coefficients' index.
    leaf: usize,
    /// `2^d`, the leaf `d` depths below the first cells.
    scale: f64,
    /// The leaf's low corner in cells of its own side (integers).
    cell: DVec3,
}

/// The Bernstein coefficients of the tricubic `Σ a_ijk u^i v^j w^k` on the unit cube (`i`
/// fastest in both): a convex combination of them at each point, so the least is a bound
/// below the polynomial there.
fn bernstein(a: &[f64; 64]) -> [f64; 64] {
    // Power to Bernstein on [0, 1] for a cubic: b_k = Σ_{i <= k} C(k, i) / C(3, i) a_i.
    const M: [[f64; 4]; 4] = [
        [1.0, 0.0, 0.0, 0.0],
        [1.0, 1.0 / 3.0, 0.0, 0.0],
        [1.0, 2.0 / 3.0, 1.0 / 3.0, 0.0],
        [1.0, 1.0, 1.0, 1.0],
    ];
    along_each_axis(*a, |_| M)
}

/// The tricubic's power coefficients after `u = lo + (hi - lo) t` on each axis: the same
/// polynomial over the box `[lo, hi]` of the unit cube, read on `t` in the unit cube.
fn restricted(a: &[f32; 64], lo: DVec3, hi: DVec3) -> [f64; 64] {
    // (lo + d t)^i = Σ_k C(i, k) lo^(i-k) d^k t^k: row k, column i.
    const C: [[f64; 4]; 4] = [
        [1.0, 1.0, 1.0, 1.0],
        [0.0, 1.0, 2.0, 3.0],
        [0.0, 0.0, 1.0, 3.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let (lo, d) = (lo.to_array(), (hi - lo).to_array());
    along_each_axis(a.map(f64::from), |axis| {
        let mut m = [[0.0; 4]; 4];
        for (k, row) in m.iter_mut().enumerate() {
            for (i, out) in row.iter_mut().enumerate().skip(k) {
                *out = C[k][i] * lo[axis].powi((i - k) as i32) * d[axis].powi(k as i32);
            }
        }
        m
    })
}

/// `b` with the 4 x 4 matrix `matrix(axis)` applied along each axis in turn (`i` fastest).
fn along_each_axis(mut b: [f64; 64], matrix: impl Fn(usize) -> [[f64; 4]; 4]) -> [f64; 64] {
    for (axis, stride) in [1, 4, 16].into_iter().enumerate() {
        let m = matrix(axis);
        let mut next = [0.0; 64];
        for (at, out) in next.iter_mut().enumerate() {
            let k = at / stride % 4;
            let base = at - k * stride;
            *out = (0..4).map(|i| m[k][i] * b[base + i * stride]).sum();
        }
        b = next;
    }
    b
}

/// Points [`Octree::distances_near`] evaluates side by side.
pub const LANES: usize = 4;

/// `Σ a_ijk u^i v^j w^k` in every lane, each summed in [`Octree::sample_inside`]'s order
/// with its products associated as there (`((a u^i) v^j) w^k`), so each lane's bits are
/// that function's. On x86-64 with AVX2 the lanes are one 256-bit vector.
fn tricubic_lanes(
    a: &[&[f32; 64]; LANES],
    pu: &[[f64; LANES]; 4],
    pv: &[[f64; LANES]; 4],
    pw: &[[f64; LANES]; 4],
) -> [f64; LANES] {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, the only feature the function is compiled for.
        return unsafe { tricubic_lanes_avx2(a, pu, pv, pw) };
    }
    tricubic_lanes_portable(a, pu, pv, pw)
}

/// [`tricubic_lanes`] compiled for AVX2 (IEEE multiplications and additions as the
/// portable code's: no fused operation is enabled, so the same bits).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn tricubic_lanes_avx2(
    a: &[&[f32; 64]; LANES],
    pu: &[[f64; LANES]; 4],
    pv: &[[f64; LANES]; 4],
    pw: &[[f64; LANES]; 4],
) -> [f64; LANES] {
    tricubic_lanes_portable(a, pu, pv, pw)
}

/// [`tricubic_lanes`] for any CPU.
#[inline(always)]
fn tricubic_lanes_portable(
    a: &[&[f32; 64]; LANES],
    pu: &[[f64; LANES]; 4],
    pv: &[[f64; LANES]; 4],
    pw: &[[f64; LANES]; 4],
) -> [f64; LANES] {
    let mut value = [0.0; LANES];
    for (k, w) in pw.iter().enumerate() {
        for (j, v) in pv.iter().enumerate() {
            for (i, u) in pu.iter().enumerate() {
                let at = i + 4 * j + 16 * k;
                for l in 0..LANES {
                    value[l] += f64::from(a[l][at]) * u[l] * v[l] * w[l];
                }
            }
        }
    }
    value
}

/// The tricubic `Σ a_ijk u^i v^j w^k` at `(u, v, w)` and its three partial derivatives,
/// side by side in four lanes: the value's terms `((a u^i) v^j) w^k`, the derivative along
/// u's `((i u^(i-1) v^j) w^k) a` (and alike along v and w), each summed in `k`, `j`, `i`
/// order (innermost last), so each lane's bits are those of its own sum alone.
fn tricubic_and_gradient(a: &[f32; 64], at: DVec3) -> [f64; 4] {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, the only feature the function is compiled for.
        return unsafe { tricubic_and_gradient_avx2(a, at) };
    }
    tricubic_and_gradient_portable(a, at)
}

/// [`tricubic_and_gradient`] compiled for AVX2 (no fused operation: the same bits).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn tricubic_and_gradient_avx2(a: &[f32; 64], at: DVec3) -> [f64; 4] {
    tricubic_and_gradient_portable(a, at)
}

/// [`tricubic_and_gradient`] for any CPU.
#[inline(always)]
fn tricubic_and_gradient_portable(a: &[f32; 64], at: DVec3) -> [f64; 4] {
    let ((pu, du), (pv, dv), (pw, dw)) = (powers(at.x), powers(at.y), powers(at.z));
    let mut sums = [0.0; 4];
    for k in 0..4 {
        for j in 0..4 {
            for i in 0..4 {
                let c = f64::from(a[i + 4 * j + 16 * k]);
                let x = [c, du[i], pu[i], pu[i]];
                let y = [pu[i], pv[j], dv[j], pv[j]];
                let z = [pv[j], pw[k], pw[k], dw[k]];
                let w = [pw[k], c, c, c];
                for l in 0..4 {
                    sums[l] += x[l] * y[l] * z[l] * w[l];
                }
            }
        }
    }
    sums
}

/// `(1, t, t², t³)` and its derivative.
fn powers(t: f64) -> ([f64; 4], [f64; 4]) {
    ([1.0, t, t * t, t * t * t], [0.0, 1.0, 2.0 * t, 3.0 * t * t])
}

impl Octree {
    /// Reads an octree of `cells` cells a side at the first depth over the cube of low
    /// `corner` and `side` (cm), from the rest of its file, `body`: the node count, the
    /// nodes, the leaf count, the coefficients. Errors name what is wrong.
    pub(crate) fn parse(
        cells: u32,
        corner: DVec3,
        side: f64,
        body: &[u8],
    ) -> Result<Octree, String> {
        let read_u32 = |at: usize| -> Result<u32, String> {
            body.get(at..at + 4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .ok_or_else(|| format!("man octree: the file ends at byte {at} of its body"))
        };
        let cells = cells as usize;
        if cells == 0 || side.is_nan() || side <= 0.0 {
            return Err(format!(
                "man octree: {cells} cells a side over a cube of side {side}"
            ));
        }
        let node_count = read_u32(0)? as usize;
        let nodes: Vec<u32> = (0..node_count)
            .map(|i| read_u32(4 + 4 * i))
            .collect::<Result<_, _>>()?;
        let leaves_at = 4 + 4 * node_count;
        let leaf_count = read_u32(leaves_at)? as usize;
        let data = &body[leaves_at + 4..];
        if data.len() != 256 * leaf_count {
            return Err(format!(
                "man octree: {} bytes of coefficients for {leaf_count} leaves (256 each)",
                data.len()
            ));
        }
        let coefficients = data
            .chunks_exact(256)
            .map(|leaf| {
                core::array::from_fn(|k| {
                    f32::from_le_bytes([
                        leaf[4 * k],
                        leaf[4 * k + 1],
                        leaf[4 * k + 2],
                        leaf[4 * k + 3],
                    ])
                })
            })
            .collect();
        let mut tree = Octree {
            low: corner,
            side,
            cells,
            cell: side / cells as f64,
            nodes,
            coefficients,
            floors: Vec::new(),
        };
        tree.check()?;
        tree.floors = tree.node_floors();
        Ok(tree)
    }

    /// [`Octree::floors`], children before their parents (a child's index is above its
    /// parent's, [`Octree::check`]).
    fn node_floors(&self) -> Vec<f64> {
        let mut floors = vec![0.0; self.nodes.len()];
        for i in (0..self.nodes.len()).rev() {
            let node = self.nodes[i];
            floors[i] = if node & LEAF != 0 {
                let b = bernstein(&self.coefficients[(node & !LEAF) as usize].map(f64::from));
                b.into_iter().fold(f64::INFINITY, f64::min)
            } else {
                let first = node as usize;
                floors[first..first + 8]
                    .iter()
                    .copied()
                    .fold(f64::INFINITY, f64::min)
            };
        }
        floors
    }

    /// Whether every distance [`Octree::sample`] gives at a point within `radius` of
    /// `centre` (field frame, cm) is above `level` (cm), by the cells' floors: `true` is
    /// certain, `false` may be wrong. Off the cube a value is its nearest point's plus a
    /// distance, and the nearest points of the ball's lie within `radius` of the centre's
    /// nearest point (the projection on a box moves two points no farther apart), so the
    /// cells searched are those meeting that ball; a cell counts where its closed extent
    /// meets it, as a point on a face may be read in either cell.
    pub fn is_above_in(&self, centre: DVec3, radius: f64, level: f64) -> bool {
        let top = self.low + DVec3::splat(self.side);
        let centre = centre.clamp(self.low, top);
        let reach = DVec3::splat(radius);
        let (lo, hi) = ((centre - reach).max(self.low), (centre + reach).min(top));
        let cell = self.cell;
        let range = |l: f64, h: f64, low: f64| {
            let first = ((l - low) / cell).floor().max(0.0) as usize;
            let last = (((h - low) / cell).floor() as usize).min(self.cells - 1);
            first..=last
        };
        let ball = (centre, radius * radius);
        for z in range(lo.z, hi.z, self.low.z) {
            for y in range(lo.y, hi.y, self.low.y) {
                for x in range(lo.x, hi.x, self.low.x) {
                    let corner = self.low + cell * DVec3::new(x as f64, y as f64, z as f64);
                    let node = (z * self.cells + y) * self.cells + x;
                    if !self.node_is_above(node, corner, cell, ball, level) {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// [`Octree::is_above_in`] in the cell of `node`, low `corner`, `size` (cm), against
    /// the ball of centre and squared radius `ball`.
    fn node_is_above(
        &self,
        node: usize,
        corner: DVec3,
        size: f64,
        ball: (DVec3, f64),
        level: f64,
    ) -> bool {
        let (centre, radius_squared) = ball;
        let nearest = centre.clamp(corner, corner + DVec3::splat(size));
        if nearest.distance_squared(centre) > radius_squared || self.floors[node] > level {
            return true;
        }
        let entry = self.nodes[node];
        if entry & LEAF != 0 {
            // The leaf's polynomial bounded on the part of its cell in the ball's box:
            // where the ball only grazes a cell, its floor over the whole cell is too low.
            let reach = DVec3::splat(radius_squared.sqrt());
            let lo = ((centre - reach - corner) / size).clamp(DVec3::ZERO, DVec3::ONE);
            let hi = ((centre + reach - corner) / size).clamp(DVec3::ZERO, DVec3::ONE);
            let a = &self.coefficients[(entry & !LEAF) as usize];
            return bernstein(&restricted(a, lo, hi))
                .into_iter()
                .fold(f64::INFINITY, f64::min)
                > level;
        }
        let half = 0.5 * size;
        (0..8).all(|child| {
            let offset = DVec3::new(
                (child & 1) as f64,
                ((child >> 1) & 1) as f64,
                ((child >> 2) & 1) as f64,
            );
            self.node_is_above(
                entry as usize + child,
                corner + half * offset,
                half,
                ball,
                level,
            )
        })
    }

    /// Every node points inside the file, and no walk from a first cell can loop.
    fn check(&self) -> Result<(), String> {
        if self.nodes.len() < self.cells.pow(3) {
            return Err(format!(
                "man octree: {} nodes, fewer than the {} first cells",
                self.nodes.len(),
                self.cells.pow(3)
            ));
        }
        for (i, &node) in self.nodes.iter().enumerate() {
            let bad = if node & LEAF != 0 {
                (node & !LEAF) as usize >= self.coefficients.len()
            } else {
                (node as usize) <= i || node as usize + 8 > self.nodes.len()
            };
            if bad {
                return Err(format!(
                    "man octree: node {i} points outside the file ({node:#x})"
                ));
            }
        }
        Ok(())
    }

    /// The cube's low corner (cm, the field's frame), the side of its first cells (cm) and
    /// their count a side.
    pub fn first_cells(&self) -> (DVec3, f64, usize) {
        (self.low, self.cell, self.cells)
    }

    /// The distance (cm) and the plugin's gradient (unit) at `point` (field frame, cm).
    /// Off the cube, the value at its nearest point plus the distance to it, and the
    /// gradient there (the plugin's `boxProjection`).
    pub fn sample(&self, point: DVec3) -> (f64, DVec3) {
        self.sample_near(point, &mut LastLeaf::default())
    }

    /// [`Octree::sample`] where `last` holds the leaf of an earlier point (updated to
    /// this one's): the same bits, the walk skipped when the point is in that leaf.
    pub fn sample_near(&self, point: DVec3, last: &mut LastLeaf) -> (f64, DVec3) {
        let inside = self.nearest_inside(point);
        let (value, gradient) = self.sample_inside(inside, last);
        (value + point.distance(inside), gradient)
    }

    /// [`Octree::sample_near`]'s distances (cm) at [`LANES`] points, each the same bits as
    /// alone, without the gradients' work: the tricubics' sums run side by side (one
    /// vector of lanes a term), so that the chain of 64 additions each needs is paid once
    /// for all of them. `last` is updated point by point, as by that many calls.
    pub fn distances_near(&self, points: &[DVec3; LANES], last: &mut LastLeaf) -> [f64; LANES] {
        let inside = points.map(|p| self.nearest_inside(p));
        let leaves = inside.map(|p| {
            let (a, frac, _) = self.leaf(p, last);
            (a, frac)
        });
        // Per term, per lane: (1, t, t², t³) on each axis, lanes innermost.
        let powers_of = |axis: fn(DVec3) -> f64| -> [[f64; LANES]; 4] {
            let p: [[f64; 4]; LANES] = leaves.map(|(_, frac)| powers(axis(frac)).0);
            core::array::from_fn(|i| core::array::from_fn(|l| p[l][i]))
        };
        let (pu, pv, pw) = (powers_of(|f| f.x), powers_of(|f| f.y), powers_of(|f| f.z));
        let value = tricubic_lanes(&leaves.map(|(a, _)| a), &pu, &pv, &pw);
        core::array::from_fn(|l| value[l] + points[l].distance(inside[l]))
    }

    /// The point of the cube nearest `point` (the plugin's `boxProjection`), kept off the
    /// top faces so that the walk stays in the last cells.
    fn nearest_inside(&self, point: DVec3) -> DVec3 {
        let top = self.low + DVec3::splat(self.side * (1.0 - 1e-12));
        point.clamp(self.low, top)
    }

    /// The leaf holding `point` (a point of the cube) as the plugin finds it: its
    /// coefficients, the point's place in it (each coordinate in [0, 1)) and its side (cm).
    ///
    /// The walk's arithmetic is exact (doubling, and taking 1 off a value in [1, 2)), so a
    /// point's place in a leaf `d` depths down is `v - floor(v)` for `v = u 2^d`, `u` its
    /// place in first cells, and the leaf is the one of cell `floor(v)` at that depth,
    /// unless the walk met a tie (a place of exactly one half, which the plugin sends to
    /// the lower child) or the clamp of the last cell: either leaves a place of 0 or 1 at
    /// the leaf. So where `last` knows the leaf of cell `floor(v)` and no place is 0, the
    /// walk would end there with that place: it is skipped; a walk ending with every place
    /// strictly inside (0, 1) is remembered.
    fn leaf(&self, point: DVec3, last: &mut LastLeaf) -> (&[f32; 64], DVec3, f64) {
        let cell = self.cell;
        let u = (point - self.low) / cell;
        // `u.floor()` without libm's call (a twentieth of the step's time): the point is in
        // the cube, so `u` is finite, at least +0 and far below 2^63, where truncating to
        // a signed integer (one instruction each way) and back is the floor, the same bits.
        let floor = |t: DVec3| {
            DVec3::new(
                (t.x as i64) as f64,
                (t.y as i64) as f64,
                (t.z as i64) as f64,
            )
        };
        if let LastLeaf(Some(known)) = *last {
            let v = u * known.scale;
            let at = floor(v);
            let frac = v - at;
            if at == known.cell && frac.cmpgt(DVec3::ZERO).all() {
                return (&self.coefficients[known.leaf], frac, cell / known.scale);
            }
        }
        let mut at = floor(u).clamp(DVec3::ZERO, DVec3::splat(self.cells as f64 - 1.0));
        let mut frac = u - at;
        let index = |v: f64| v as usize;
        let mut node =
            self.nodes[(index(at.z) * self.cells + index(at.y)) * self.cells + index(at.x)];
        let mut scale = 1.0;
        while node & LEAF == 0 {
            let half = |t: f64| usize::from(t > 0.5);
            let upper = [half(frac.x), half(frac.y), half(frac.z)];
            node = self.nodes[node as usize + upper[0] + 2 * upper[1] + 4 * upper[2]];
            at = 2.0 * at + DVec3::from(upper.map(|h| h as f64));
            // `(2 frac).fract()` without libm's `trunc` call: `2 frac` is in [0, 2) and
            // `x - 1` is exact there, so the same bits.
            frac = (2.0 * frac)
                .to_array()
                .map(|t| if t >= 1.0 { t - 1.0 } else { t })
                .into();
            scale *= 2.0;
        }
        let leaf = (node & !LEAF) as usize;
        if frac.cmpgt(DVec3::ZERO).all() && frac.cmplt(DVec3::ONE).all() {
            *last = LastLeaf(Some(KnownLeaf {
                leaf,
                scale,
                cell: at,
            }));
        }
        (&self.coefficients[leaf], frac, cell / scale)
    }

    /// [`Octree::sample_near`] at a point of the cube.
    fn sample_inside(&self, point: DVec3, last: &mut LastLeaf) -> (f64, DVec3) {
        let (a, frac, size) = self.leaf(point, last);
        let [value, gx, gy, gz] = tricubic_and_gradient(a, frac);
        (value, (DVec3::new(gx, gy, gz) / size).normalize_or_zero())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform draws in [0, 1) from `seed` (a 64-bit linear congruential stream, top 53
    /// bits): the tests' coefficients and places.
    fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The value and gradient side by side are each sum's bits alone (the value as
    /// [`tricubic_lanes`] sums it, the gradient as `Σ a (∂ of the term)` in a `DVec3`), on
    /// the vector build and the portable one: 200 draws of coefficients and places.
    #[test]
    fn the_value_and_gradient_side_by_side_are_each_sums_bits() {
        let mut draw = uniform(0x2545_f491_4f6c_dd1d);
        for _ in 0..200 {
            let a: [f32; 64] = core::array::from_fn(|_| (20.0 * draw() - 10.0) as f32);
            let at = DVec3::new(draw(), draw(), draw());
            let ((pu, du), (pv, dv), (pw, dw)) = (powers(at.x), powers(at.y), powers(at.z));
            let (mut value, mut gradient) = (0.0, DVec3::ZERO);
            for k in 0..4 {
                for j in 0..4 {
                    for i in 0..4 {
                        let c = f64::from(a[i + 4 * j + 16 * k]);
                        value += c * pu[i] * pv[j] * pw[k];
                        gradient += c * DVec3::new(
                            du[i] * pv[j] * pw[k],
                            pu[i] * dv[j] * pw[k],
                            pu[i] * pv[j] * dw[k],
                        );
                    }
                }
            }
            let alone = [value, gradient.x, gradient.y, gradient.z].map(f64::to_bits);
            assert_eq!(tricubic_and_gradient(&a, at).map(f64::to_bits), alone);
            assert_eq!(
                tricubic_and_gradient_portable(&a, at).map(f64::to_bits),
                alone
            );
        }
    }

    /// The vector build of the lanes' sums (where the CPU has one) gives the portable
    /// build's bits: 200 draws of four leaves' coefficients and places.
    #[test]
    fn the_lanes_sums_are_the_same_bits_on_every_path() {
        let mut draw = uniform(0x9e37_79b9_7f4a_7c15);
        for _ in 0..200 {
            let leaves: [[f32; 64]; LANES] =
                core::array::from_fn(|_| core::array::from_fn(|_| (20.0 * draw() - 10.0) as f32));
            let places: [[f64; 3]; LANES] = core::array::from_fn(|_| [draw(), draw(), draw()]);
            let axis = |k: usize| -> [[f64; LANES]; 4] {
                core::array::from_fn(|i| core::array::from_fn(|l| powers(places[l][k]).0[i]))
            };
            let a = core::array::from_fn(|l| &leaves[l]);
            let (pu, pv, pw) = (axis(0), axis(1), axis(2));
            let fast = tricubic_lanes(&a, &pu, &pv, &pw);
            let portable = tricubic_lanes_portable(&a, &pu, &pv, &pw);
            assert_eq!(fast.map(f64::to_bits), portable.map(f64::to_bits));
        }
    }
}
