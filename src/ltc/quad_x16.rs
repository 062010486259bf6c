//! Plain-quad children, 16 lanes wide: the scalar [`super::quad`] kernel
//! with the 4 children × 4 edges in the 16 lanes of one vector. Each lane
//! maps and normalises the start corner of its edge — the 9 grid corners,
//! some twice, computed exactly as the scalar kernel computes them once —
//! and the edge ends are the next edge's starts, one 128-bit block shuffle
//! away. Interior edges are thus evaluated twice, once per orientation, but
//! one vector costs the same whether it holds 12 edges or 16. Every lane
//! performs the scalar kernel's operations in its order.
//!
//! The edge lanes are transposed with respect to the paper's 4k + e: edge e
//! of child k sits in 128-bit block `BLOCK_OF_EDGE[e]`, lane k of it. The
//! per-child sums (e0 + e1) + (e2 + e3) — the scalar order — are then two
//! block additions (upper 256 bits onto lower, upper 128 onto lower) that
//! leave the 4 children in one f32x4, and the edge ends a block rotation.

use super::children::{GlossyLtc, HorizonSide};
use super::fast_math::{dyadic_sincos, step_sincos};
use super::simd::{
    BLOCK_OF_EDGE, block_sums, cross_xy, edge_end_blocks, heights_and_radii, normalise,
    rotated_sincos, shuffle_blocks, splat, unit_edges_z,
};
use crate::directional::Cell;
use glam::Vec3;
use wide::{f32x4, f32x16};

/// Block order taking edge starts to edge ends.
const END_BLOCKS: i32 = edge_end_blocks(4);

/// Start corner of each lane's edge as (height index, azimuth side −1..1)
/// of the node's 3×3 grid. Child k = (iu, iv) = (k & 1, k >> 1) runs
/// (iu,iv)→(iu,iv+1)→(iu+1,iv+1)→(iu+1,iv)→(iu,iv), the scalar winding.
const fn edge_starts(height: bool) -> [f32; 16] {
    let mut t = [0.0f32; 16];
    let mut k = 0;
    while k < 4 {
        let (iu, iv) = (k & 1, k >> 1);
        let corners = [(iu, iv), (iu, iv + 1), (iu + 1, iv + 1), (iu + 1, iv)];
        let mut e = 0;
        while e < 4 {
            let (zi, vi) = corners[e];
            t[4 * BLOCK_OF_EDGE[e] + k] = if height { zi as f32 } else { vi as f32 - 1.0 };
            e += 1;
        }
        k += 1;
    }
    t
}
const START_HEIGHT: [f32; 16] = edge_starts(true);
const START_SIDE: [f32; 16] = edge_starts(false);

/// Lanes holding the corners of child k: its 4 edge starts.
const fn child_lanes() -> [u32; 4] {
    let mut m = [0u32; 4];
    let mut k = 0;
    while k < 4 {
        let mut e = 0;
        while e < 4 {
            m[k] |= 1 << (4 * BLOCK_OF_EDGE[e] + k);
            e += 1;
        }
        k += 1;
    }
    m
}
const CHILD_LANES: [u32; 4] = child_lanes();

/// Edge starts and ends (unit vectors in the lobe's cosine space) of the
/// 16 lanes: the scalar kernel's `node_grid` and `unit_grid_vertex`, lane by
/// lane.
#[inline(always)]
fn edge_ends(g: &GlossyLtc, cell: Cell) -> ([f32x16; 3], [f32x16; 3]) {
    let d = cell.depth + 1;
    let h = 1.0 / (1u64 << d) as f32;
    let (z, r) = heights_and_radii(2 * cell.ix, h, f32x16::from(START_HEIGHT));
    let (s, c) = rotated_sincos(
        dyadic_sincos(2 * cell.iy as u64 + 1, d),
        step_sincos(d),
        f32x16::from(START_SIDE),
    );
    // r·P(φ) + Q(z), as the scalar `grid_columns` and `unit_grid_vertex`.
    let rw = &g.rows;
    let col = |i: usize| splat(rw[i][1]).mul_add(s, splat(rw[i][0]) * c);
    let t = [0, 1, 2].map(|i| r.mul_add(col(i), splat(rw[i][2]) * z));
    let a = normalise(t);
    let b = a.map(shuffle_blocks::<END_BLOCKS>);
    (a, b)
}

/// The 4 child integrals of a node whose children are plain quads.
#[inline]
pub fn quad_children_x16(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    let (a, b) = edge_ends(g, cell);
    // Every corner is some lane's edge start.
    let above = a[2].simd_ge(splat(0.0));
    let (cz, k) = unit_edges_z(&a, &b);
    if above.all() {
        // Every child above the horizon: F_z is the integral.
        let scale = g.orientation * (0.5 / std::f32::consts::PI);
        let f = (block_sums(cz * k) * f32x4::splat(scale)).fast_max(f32x4::splat(0.0));
        return f.to_array();
    }
    below_or_across(g, cell)
}

/// The children when some are not wholly above the horizon: out of line,
/// so that the common case keeps its registers and a short prologue. It
/// recomputes the edges (the same operations, so the same values) rather
/// than have the common case spill them for it.
#[cold]
#[inline(never)]
fn below_or_across(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    let (a, b) = edge_ends(g, cell);
    let (cz, k) = unit_edges_z(&a, &b);
    let above = a[2].simd_ge(splat(0.0)).to_bitmask();
    let below = a[2].simd_le(splat(0.0)).to_bitmask();
    let sides = CHILD_LANES.map(|m| HorizonSide::of_masks(above, below, m));
    let fz = block_sums(cz * k).to_array();
    let (fx, fy) = if sides.contains(&HorizonSide::Crossing) {
        let (cx, cy) = cross_xy(&a, &b);
        (block_sums(cx * k).to_array(), block_sums(cy * k).to_array())
    } else {
        ([0.0; 4], [0.0; 4])
    };
    let sums = std::array::from_fn(|k| Vec3::new(fx[k], fy[k], fz[k]));
    g.finish_children(cell, sums, sides, None)
}
