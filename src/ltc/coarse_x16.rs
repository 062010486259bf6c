//! Children with subdivided parallels, 16 edges per vector: the scalar
//! [`super::coarse`] kernel's per-edge operations, lane by lane, over the
//! node's edge table; both kernels then share [`super::coarse::finish_coarse`].

use super::children::GlossyLtc;
use super::coarse::{CoarseEdges, coarse_node, finish_coarse};
use super::simd::{above_part_z, horizon_points, load16, splat, unit_edges, unit_vertices};
use crate::directional::Cell;

/// The 4 child integrals of a coarse node (depth 1..=4), 16 edges at a time.
pub fn coarse_children_x16(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    let node = coarse_node(cell, g.plain_quad_depth);
    let mut e = CoarseEdges::new();
    let mut j = 0;
    while j < node.len {
        let ld = |v: &[Vec<f32>; 3]| [load16(&v[0], j), load16(&v[1], j), load16(&v[2], j)];
        let (wa, wb) = (ld(&node.a), ld(&node.b));
        let ua = unit_vertices(&g.rows, wa[0], wa[1], wa[2]);
        let ub = unit_vertices(&g.rows, wb[0], wb[1], wb[2]);
        let zero = splat(0.0);
        let (a_up, b_up) = (ua[2].simd_ge(zero), ub[2].simd_ge(zero));
        let below = ua[2].simd_le(zero) & ub[2].simd_le(zero);
        let both = a_up & b_up;
        e.above |= (both.to_bitmask() as u128) << j;
        e.below |= (below.to_bitmask() as u128) << j;
        e.a_up |= (a_up.to_bitmask() as u128) << j;
        let (c, k) = unit_edges(ua, ub);
        let ez = c[2] * k;
        e.ez[j..j + 16].copy_from_slice(&ez.to_array());
        let mut clip = both.bitselect(ez, zero);
        let crossing = a_up ^ b_up;
        let bits = crossing.to_bitmask();
        if bits != 0 {
            e.crossing |= (bits as u128) << j;
            let p = horizon_points(ua, ub);
            e.px[j..j + 16].copy_from_slice(&p[0].to_array());
            e.py[j..j + 16].copy_from_slice(&p[1].to_array());
            clip = crossing.bitselect(above_part_z(ua, ub, p, a_up), clip);
        }
        e.clip[j..j + 16].copy_from_slice(&clip.to_array());
        j += 16;
    }
    finish_coarse(g, node, &e)
}
