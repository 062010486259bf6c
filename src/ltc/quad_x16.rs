//! Plain-quad children, 16 lanes wide: the scalar [`super::quad`] kernel
//! with the 9 grid corners in lanes 0..9 of one vector (mapped and
//! normalised in one pass) and the 4 children × 4 edges in the 16 lanes of
//! another (lane 4k + e is edge e of child k, as in the paper), gathered
//! from the corners by two constant permutations. Interior edges are thus
//! evaluated twice, once per orientation, but one vector costs the same
//! whether it holds 12 edges or 16. Every lane performs the scalar kernel's
//! operations in its order, and the per-child sums (e0 + e1) + (e2 + e3) are
//! formed in registers by two lane swaps.

use super::children::{GlossyLtc, HorizonSide};
use super::fast_math::dyadic_sincos;
use super::simd::{heights_and_radii, permute, rotated_sincos, splat, unit_edges, unit_vertices};
use crate::directional::Cell;
use glam::Vec3;
use wide::f32x16;

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
            t[4 * k + e] = 3 * c.0 + c.1;
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

/// Lane swaps that add neighbours, then pairs, within each group of 4.
const SWAP1: [i32; 16] = [1, 0, 3, 2, 5, 4, 7, 6, 9, 8, 11, 10, 13, 12, 15, 14];
const SWAP2: [i32; 16] = [2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14, 15, 12, 13];

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

/// (e0 + e1) + (e2 + e3) of each group of 4 lanes, in lane 4k.
#[inline(always)]
fn group_sums(e: f32x16) -> f32x16 {
    let y = e + permute(e, &SWAP1);
    y + permute(y, &SWAP2)
}

/// The 4 child integrals of a node whose children are plain quads.
pub fn quad_children_x16(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    // The scalar kernel's `node_grid`, lane by lane.
    let d = cell.depth + 1;
    let h = 1.0 / (1u64 << d) as f32;
    let (z, r) = heights_and_radii((2 * cell.ix) as f32, h, f32x16::from(GRID_HEIGHT));
    let (s, c) = rotated_sincos(
        dyadic_sincos(2 * cell.iy as u64 + 1, d),
        dyadic_sincos(1, d),
        f32x16::from(GRID_SIDE),
    );
    let u = unit_vertices(&g.rows, r * c, r * s, z);
    let above = u[2].simd_ge(splat(0.0)).to_bitmask();
    let below = u[2].simd_le(splat(0.0)).to_bitmask();
    let a = [
        permute(u[0], &PERM_A),
        permute(u[1], &PERM_A),
        permute(u[2], &PERM_A),
    ];
    let b = [
        permute(u[0], &PERM_B),
        permute(u[1], &PERM_B),
        permute(u[2], &PERM_B),
    ];
    let ([cx, cy, cz], k) = unit_edges(a, b);
    let scale = g.orientation * (0.5 / std::f32::consts::PI);
    if above & ALL_CORNERS == ALL_CORNERS {
        // Every child above the horizon: F_z is the integral.
        let f = (group_sums(cz * k) * splat(scale)).fast_max(splat(0.0));
        let f = f.to_array();
        return [f[0], f[4], f[8], f[12]];
    }
    let sides = CHILD_CORNERS.map(|m| HorizonSide::of_masks(above, below, m));
    let fz = group_sums(cz * k).to_array();
    let (fx, fy) = if sides.contains(&HorizonSide::Crossing) {
        (group_sums(cx * k).to_array(), group_sums(cy * k).to_array())
    } else {
        ([0.0; 16], [0.0; 16])
    };
    let sums = std::array::from_fn(|k| Vec3::new(fx[4 * k], fy[4 * k], fz[4 * k]));
    g.finish_children(cell, sums, sides, None)
}
