//! Plain-quad children, 16 lanes wide: the scalar [`super::quad`] kernel
//! with the 9 grid corners in lanes 0..9 of one vector (mapped and
//! normalised in one pass) and the 4 children × 4 edges in the 16 lanes of
//! another, gathered from the corners by two constant permutations.
//! Interior edges are thus evaluated twice, once per orientation, but one
//! vector costs the same whether it holds 12 edges or 16. Every lane
//! performs the scalar kernel's operations in its order.
//!
//! The edge lanes are transposed with respect to the paper's 4k + e: edge e
//! of child k sits in 128-bit block `BLOCK_OF_EDGE[e]`, lane k of it. The
//! per-child sums (e0 + e1) + (e2 + e3) — the scalar order — are then two
//! block additions (upper 256 bits onto lower, upper 128 onto lower) that
//! leave the 4 children in one f32x4, instead of two lane permutations, two
//! additions and a gather of lanes 0, 4, 8, 12.

use super::children::{GlossyLtc, HorizonSide};
use super::fast_math::{dyadic_sincos, step_sincos};
use super::simd::{
    block_sums, cross_xy, heights_and_radii, normalise, permute, rotated_sincos, splat,
    unit_edges_z,
};
use crate::directional::Cell;
use glam::Vec3;
use wide::{f32x4, f32x16};

/// The 128-bit block holding edge e of every child: blocks 0 + 2 and
/// 1 + 3 are added first, so e0, e1 and e2, e3 must sit in those pairs.
const BLOCK_OF_EDGE: [usize; 4] = [0, 2, 1, 3];

/// Corner (height index, azimuth index) of each lane's edge start (`a`) or
/// end (`b`), as a grid lane 3·zi + vi. Child k = (iu, iv) = (k & 1, k >> 1)
/// runs (iu,iv)→(iu,iv+1)→(iu+1,iv+1)→(iu+1,iv)→(iu,iv), the scalar winding.
const fn edge_lanes(end: bool) -> [i32; 16] {
    let mut t = [0i32; 16];
    let mut k = 0;
    while k < 4 {
        let (iu, iv) = ((k & 1) as i32, (k >> 1) as i32);
        let corners = [(iu, iv), (iu, iv + 1), (iu + 1, iv + 1), (iu + 1, iv)];
        let mut e = 0;
        while e < 4 {
            let c = if end {
                corners[(e + 1) % 4]
            } else {
                corners[e]
            };
            t[4 * BLOCK_OF_EDGE[e] + k] = 3 * c.0 + c.1;
            e += 1;
        }
        k += 1;
    }
    t
}
const PERM_A: [i32; 16] = edge_lanes(false);
const PERM_B: [i32; 16] = edge_lanes(true);

/// Height index and azimuth side (−1, 0, 1) of grid lane 3·zi + vi
/// (lanes 9.. repeat corner 0).
const fn grid_lanes(height: bool) -> [f32; 16] {
    let mut t = [0.0f32; 16];
    let mut l = 0;
    while l < 16 {
        let (zi, vi) = if l < 9 { (l / 3, l % 3) } else { (0, 0) };
        t[l] = if height { zi as f32 } else { vi as f32 - 1.0 };
        l += 1;
    }
    t
}
const GRID_HEIGHT: [f32; 16] = grid_lanes(true);
const GRID_SIDE: [f32; 16] = grid_lanes(false);

/// Corner lanes of each child in the grid vector.
const fn child_corner_masks() -> [u32; 4] {
    let mut m = [0u32; 4];
    let mut k = 0;
    while k < 4 {
        let (iu, iv) = (k & 1, k >> 1);
        m[k] = (1 << (3 * iu + iv))
            | (1 << (3 * iu + iv + 1))
            | (1 << (3 * (iu + 1) + iv))
            | (1 << (3 * (iu + 1) + iv + 1));
        k += 1;
    }
    m
}
const CHILD_CORNERS: [u32; 4] = child_corner_masks();
const ALL_CORNERS: u32 = 0x1FF;

/// The 4 child integrals of a node whose children are plain quads.
#[inline]
pub fn quad_children_x16(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    // The scalar kernel's `node_grid`, lane by lane.
    let d = cell.depth + 1;
    let h = 1.0 / (1u64 << d) as f32;
    let (z, r) = heights_and_radii(2 * cell.ix, h, f32x16::from(GRID_HEIGHT));
    let (s, c) = rotated_sincos(
        dyadic_sincos(2 * cell.iy as u64 + 1, d),
        step_sincos(d),
        f32x16::from(GRID_SIDE),
    );
    // r·P(φ) + Q(z), as the scalar `grid_columns` and `unit_grid_vertex`.
    let rw = &g.rows;
    let col = |i: usize| splat(rw[i][1]).mul_add(s, splat(rw[i][0]) * c);
    let t = [0, 1, 2].map(|i| r.mul_add(col(i), splat(rw[i][2]) * z));
    let u = normalise(t);
    let above = u[2].simd_ge(splat(0.0)).to_bitmask();
    let a = u.map(|v| permute(v, &PERM_A));
    let b = u.map(|v| permute(v, &PERM_B));
    let (cz, k) = unit_edges_z(&a, &b);
    let scale = g.orientation * (0.5 / std::f32::consts::PI);
    if above & ALL_CORNERS == ALL_CORNERS {
        // Every child above the horizon: F_z is the integral.
        let f = (block_sums(cz * k) * f32x4::splat(scale)).fast_max(f32x4::splat(0.0));
        return f.to_array();
    }
    let below = u[2].simd_le(splat(0.0)).to_bitmask();
    below_or_across(g, cell, [above, below], &a, &b, cz * k, k)
}

/// The children when some are not wholly above the horizon: out of line,
/// so that the common case keeps its registers and a short prologue.
#[cold]
#[inline(never)]
fn below_or_across(
    g: &GlossyLtc,
    cell: Cell,
    [above, below]: [u32; 2],
    a: &[f32x16; 3],
    b: &[f32x16; 3],
    ez: f32x16,
    k: f32x16,
) -> [f32; 4] {
    let sides = CHILD_CORNERS.map(|m| HorizonSide::of_masks(above, below, m));
    let fz = block_sums(ez).to_array();
    let (fx, fy) = if sides.contains(&HorizonSide::Crossing) {
        let (cx, cy) = cross_xy(a, b);
        (block_sums(cx * k).to_array(), block_sums(cy * k).to_array())
    } else {
        ([0.0; 4], [0.0; 4])
    };
    let sums = std::array::from_fn(|k| Vec3::new(fx[k], fy[k], fz[k]));
    g.finish_children(cell, sums, sides, None)
}
