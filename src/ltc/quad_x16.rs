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
//!
//! The kernel is throughput-bound (two independent nodes per call run no
//! faster per node), so what counts is issue slots on the two ports that
//! take vector operations while zmm ones are in flight (xmm included): per
//! node, on the short-edge path, 42 zmm and 12 narrower arithmetic
//! operations in the AVX-512 build (66 and 17 before this layout), the
//! rest loads; 38 zmm down to depth 11, where the azimuths' low table
//! entry is the identity and its rotation is skipped. Quantities with 3
//! distinct values per node (heights) are formed 4 wide and spread by one
//! permutation; depth-only lane constants, table entries and the lobe's
//! numbers are loaded, never formed or broadcast from registers; the
//! integral's scale rides in the short-edge polynomial's coefficients; and
//! the vertices are kept at length 2 to spare the Newton step's halving
//! (powers of 2 are exact, so the result is still the scalar's bit for
//! bit).

use super::children::{GlossyLtc, HorizonSide};
use super::fast_math::{
    DYADIC_BITS, RSQRT_FLOOR, SHORT_EDGE_MIN_COS, dyadic_entry_refs, dyadic_low_is_identity,
    rsqrt_estimate_x16, step_sincos, theta_over_sin_x16,
};
use super::lanes::f32x16;
use super::quad::{POLE_R2_FLOOR, quad_children_scalar};
use super::simd::{
    BLOCK_OF_EDGE, block_sums, broadcast_coeff, broadcast_entry, broadcast_pair, cross_xy,
    edge_end_blocks, not_ge_mask, shuffle_blocks, splat, spread4, unit_edges_z,
};
use crate::directional::Cell;
use glam::Vec3;
use std::sync::LazyLock;
use wide::{f32x4, i32x4};

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

/// [`START_HEIGHT`] as permutation indices.
const START_HEIGHT_INDEX: [i32; 16] = {
    let mut t = [0i32; 16];
    let mut l = 0;
    while l < 16 {
        t[l] = START_HEIGHT[l] as i32;
        l += 1;
    }
    t
};

/// Per child depth, the lane constants that only depend on the depth: the
/// rotation of each lane's azimuth from the node's centre meridian, cos
/// (exactly 1 on the centre) and sin (side × sin of a child's width), as
/// [`super::quad::node_grid`] forms them, and 2h·j of the grid heights
/// j = 0, 1, 2 (h the child's height in u) with 4h, the node's height.
/// Loaded rather than formed, they cost no issue slots.
struct DepthLanes {
    cos_off: [f32; 16],
    sin_off: [f32; 16],
    two_h_j: [f32; 4],
    four_h: f32,
}

static DEPTH_LANES: LazyLock<[DepthLanes; DYADIC_BITS as usize + 1]> =
    LazyLock::new(|| std::array::from_fn(|d| depth_lanes(d as u32)));

fn depth_lanes(d: u32) -> DepthLanes {
    let (ss, cs) = step_sincos(d);
    let two_h = 2.0 / (1u64 << d.min(63)) as f32;
    DepthLanes {
        cos_off: START_SIDE.map(|s| if s == 0.0 { 1.0 } else { cs }),
        sin_off: START_SIDE.map(|s| s * ss),
        two_h_j: [0.0, two_h, 2.0 * two_h, 0.0],
        four_h: 2.0 * two_h,
    }
}

/// Edge starts and ends in the lobe's cosine space, of length 2, of the 16
/// lanes: twice the scalar kernel's `node_grid` corners through
/// `unit_grid_vertex`, lane by lane. The 3 heights and cotangents are
/// formed 4 wide and spread: with M = ix·4h + j·2h = (u + j)·2h (exact,
/// u = 2·ix as in the scalar `child_grid`), z = M − 1 and
/// 1 ∓ z = 2 − M, M exactly, so these are the scalar's values bit for bit.
/// The Newton step of 1/|t| is y·(3 − |t|²y²), twice the scalar's
/// y·(1.5 − ½|t|²y²) exactly (one multiplication fewer), so every vertex is
/// exactly twice the scalar's, and cross and dot products 4 times.
#[inline(always)]
fn edge_ends(g: &GlossyLtc, cell: Cell) -> ([f32x16; 3], [f32x16; 3]) {
    let d = cell.depth + 1;
    let lanes = &DEPTH_LANES[d as usize];
    // `u` (< 2^24, so exact in f32) converted lane-wise: see
    // `heights_and_radii` on why not a scalar conversion. (Converting it
    // straight from memory spares a shuffle, 1.5–3 % of the kernel bench,
    // but the API's callers hold the cell in registers: the round trip
    // through the stack made levels 6–8 4–5 % slower there, session 57.)
    let ix = i32x4::splat(cell.ix as i32).round_float();
    let m = ix.mul_add(f32x4::splat(lanes.four_h), f32x4::from(lanes.two_h_j));
    let zq = m - f32x4::splat(1.0);
    let cot = zq
        / (f32x4::splat(2.0) - m)
            .mul_add(m, f32x4::splat(POLE_R2_FLOOR))
            .sqrt();
    let cot = spread4(cot, &START_HEIGHT_INDEX);
    // The scalar `rotate_by_entries`, lane by lane, the entries broadcast
    // from memory: no scalar arithmetic, no register broadcasts.
    let (high, low) = dyadic_entry_refs(2 * cell.iy as u64 + 1, d);
    let (co, so) = (f32x16::from(lanes.cos_off), f32x16::from(lanes.sin_off));
    // Down to depth 11 the low entry is exactly the identity, and so is
    // its rotation: 4 of the kernel's ~42 vector operations spared at the
    // levels most descents take, with the scalar's values bit for bit.
    let (ec, es) = if dyadic_low_is_identity(d) {
        (co, so)
    } else {
        let (sl, cl) = (broadcast_pair::<0>(low), broadcast_pair::<1>(low));
        (cl.mul_add(co, -(sl * so)), sl.mul_add(co, cl * so))
    };
    let (sh, ch) = (broadcast_pair::<0>(high), broadcast_pair::<1>(high));
    let (s, c) = (sh.mul_add(ec, ch * es), ch.mul_add(ec, -(sh * es)));
    // P(φ) + cot θ·A·ẑ, as the scalar `grid_columns` and `unit_grid_vertex`
    // (the first of the quad rows has no z entry).
    let rw = &g.quad_rows;
    let p = |a0: f32x16, a1: f32x16| a1.mul_add(s, a0 * c);
    let t = [
        p(broadcast_entry::<0, 0>(rw), broadcast_entry::<0, 1>(rw)),
        cot.mul_add(
            broadcast_entry::<1, 2>(rw),
            p(broadcast_entry::<1, 0>(rw), broadcast_entry::<1, 1>(rw)),
        ),
        cot.mul_add(
            broadcast_entry::<2, 2>(rw),
            p(broadcast_entry::<2, 0>(rw), broadcast_entry::<2, 1>(rw)),
        ),
    ];
    let n2 = t[2].mul_add(
        t[2],
        t[1].mul_add(t[1], t[0].mul_add(t[0], splat(RSQRT_FLOOR))),
    );
    let y = rsqrt_estimate_x16(n2);
    let inv2 = y * (-n2).mul_add(y * y, splat(3.0));
    let a = t.map(|v| v * inv2);
    let b = a.map(shuffle_blocks::<END_BLOCKS>);
    (a, b)
}

/// Nodes past the tables' resolution (no quadtree goes this deep): the
/// scalar kernel.
#[cold]
#[inline(never)]
fn past_the_tables(g: &GlossyLtc, depth: u32, ix: u32, iy: u32) -> [f32; 4] {
    quad_children_scalar(g, Cell { depth, ix, iy })
}

/// The 4 child integrals of a node whose children are plain quads.
#[inline]
pub fn quad_children_x16(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    if cell.depth + 1 > DYADIC_BITS {
        return past_the_tables(g, cell.depth, cell.ix, cell.iy);
    }
    let (a, b) = edge_ends(g, cell);
    // 4·a·b of the scalar's unit vectors.
    let d4 = a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0]));
    // Every corner is some lane's edge start; NaN fails both tests.
    let below = not_ge_mask(a[2], 0.0);
    let long = not_ge_mask(d4, 4.0 * SHORT_EDGE_MIN_COS);
    if below | long == 0 {
        // Every child above the horizon and every edge short (the scalar
        // kernel's `short_node`): F_z is the integral, with 4·(a×b)_z fused
        // and the scale in the polynomial. Each of its steps is the
        // scalar's ÷ a power of 2 exactly (cosines 4·d, coefficients
        // ÷ 4^(k+1)), so cz4·k is the scalar's cz·k bit for bit.
        let cz4 = a[0].mul_add(b[1], -(a[1] * b[0]));
        let c = &g.short_poly_by_4;
        let k = broadcast_coeff::<3>(c)
            .mul_add(d4, broadcast_coeff::<2>(c))
            .mul_add(d4, broadcast_coeff::<1>(c))
            .mul_add(d4, broadcast_coeff::<0>(c));
        return block_sums(cz4 * k).fast_max(f32x4::splat(0.0)).to_array();
    }
    if below == 0 {
        let cz4 = a[0] * b[1] - a[1] * b[0];
        let (cz, d) = (cz4 * splat(0.25), d4 * splat(0.25));
        let k = theta_over_sin_x16(d, || {
            let (cx, cy) = cross_xy(&a, &b);
            cz4.mul_add(cz4, cy.mul_add(cy, cx * cx)) * splat(1.0 / 16.0)
        });
        let scale = g.orientation * (0.5 / std::f32::consts::PI);
        let f = (block_sums(cz * k) * f32x4::splat(scale)).fast_max(f32x4::splat(0.0));
        return f.to_array();
    }
    below_or_across(g, cell.depth, cell.ix, cell.iy)
}

/// The children when some are not wholly above the horizon: out of line,
/// so that the common case keeps its registers and a short prologue. It
/// recomputes the edges (the same operations, so the same values) rather
/// than have the common case spill them for it.
#[cold]
#[inline(never)]
fn below_or_across(g: &GlossyLtc, depth: u32, ix: u32, iy: u32) -> [f32; 4] {
    // Its one caller has already sent nodes past the tables to the scalar.
    let cell = Cell { depth, ix, iy };
    let (a, b) = edge_ends(g, cell);
    let (a, b) = (a.map(|v| v * splat(0.5)), b.map(|v| v * splat(0.5)));
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
