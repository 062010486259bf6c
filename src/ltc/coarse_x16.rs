//! Children with subdivided parallels, 16 slots per vector: the scalar
//! [`super::coarse`] kernel's per-vertex and per-edge operations, lane by
//! lane. Each batch of chord vertices is mapped once; a chord's end is the
//! next lane's start (one lane shift across two batches), the meridians off
//! the snake are one batch of their own, and each child's signed sum grows
//! by one fused multiply-add with its slot signs per batch as the edges
//! come. The per-slot terms a child across the horizon needs are kept
//! batch by batch for the shared [`super::coarse::finish_coarse`].

use super::children::GlossyLtc;
use super::coarse::{
    CoarseNode, CrossingTerms, MAX_BATCHES, MERIDIAN_ENDS, SlotMasks, accumulate, child_integral,
    coarse_node, finish_coarse, reduce4,
};
use super::lanes::f32x16;
use super::simd::{
    above_part_z, horizon_points, permute, splat, successor_lanes, unit_edges_z, unit_vertices,
};
use crate::directional::Cell;
use glam::Vec3;
use std::mem::MaybeUninit;

/// A batch of world vertices mapped by the lobe and normalised.
#[inline(always)]
fn unit_batch(g: &GlossyLtc, v: &[[f32; 16]; 3]) -> [f32x16; 3] {
    unit_vertices(
        &g.rows,
        f32x16::from(v[0]),
        f32x16::from(v[1]),
        f32x16::from(v[2]),
    )
}

/// Runs `edge(b, starts, ends)` over the node's slot batches in order: the
/// chord batches (each lane's end its successor's start), then the
/// meridians, gathered from the unit vertices when they are one batch
/// (the guider's chords of 1/16 turn, and level 5 at 1/64), or else mapped
/// from their own world endpoints.
#[inline(always)]
fn for_each_batch(
    g: &GlossyLtc,
    node: &CoarseNode,
    mut edge: impl FnMut(usize, [f32x16; 3], [f32x16; 3]),
) {
    let batches = node.vertices.len();
    let first = unit_batch(g, &node.vertices[0]);
    let mut start = first;
    for b in 0..batches {
        let next = match node.vertices.get(b + 1) {
            Some(v) => unit_batch(g, v),
            None => [splat(0.0); 3],
        };
        let end = std::array::from_fn(|i| successor_lanes(start[i], next[i]));
        edge(b, start, end);
        start = next;
    }
    if batches == 1 {
        let (from, to) = (&node.meridian_start, &node.meridian_end);
        edge(
            batches,
            first.map(|v| permute(v, from)),
            first.map(|v| permute(v, to)),
        );
    } else {
        let m = unit_batch(g, &node.meridians);
        edge(batches, m, m.map(|v| permute(v, &MERIDIAN_ENDS)));
    }
}

/// Per-slot terms kept by the wide kernel: each batch's whole terms, and
/// for a batch with a crossing edge, its above-horizon parts and crossing
/// points. Written batch by batch and read only where written (every
/// batch's whole terms; a crossing slot's part), so nothing is zeroed.
struct KeptTerms {
    whole: [MaybeUninit<f32x16>; MAX_BATCHES],
    /// Part term, crossing x, crossing y.
    part: [MaybeUninit<[f32x16; 3]>; MAX_BATCHES],
}

impl CrossingTerms for KeptTerms {
    fn whole(&self, b: usize) -> f32x16 {
        // SAFETY: every batch of the node's slots was written.
        unsafe { self.whole[b].assume_init() }
    }

    fn part(&self, b: usize) -> f32x16 {
        // SAFETY: asked only of batches with a crossing slot, all written.
        unsafe { self.part[b].assume_init_ref()[0] }
    }

    fn point(&self, j: usize) -> Vec3 {
        // SAFETY: asked only for crossing slots, whose batch was written.
        let p = unsafe { self.part[j / 16].assume_init_ref() };
        let l = j % 16;
        Vec3::new(p[1].as_array()[l], p[2].as_array()[l], 0.0)
    }
}

/// The 4 child integrals of a coarse node (depth 1..=4), 16 slots at a time.
pub fn coarse_children_x16(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    let node = coarse_node(cell, g.plain_quad_depth);
    let zero = splat(0.0);
    let mut acc = [zero; 4];
    // Per batch: slots wholly above, wholly below, starting above, crossing.
    let mut masks = [[0u16; MAX_BATCHES]; 4];
    let mut not_above = 0u16;
    let mut kept = KeptTerms {
        whole: [const { MaybeUninit::uninit() }; MAX_BATCHES],
        part: [const { MaybeUninit::uninit() }; MAX_BATCHES],
    };
    for_each_batch(
        g,
        node,
        #[inline(always)]
        |b, ua, ub| {
            let (cz, k) = unit_edges_z(&ua, &ub);
            let ez = cz * k;
            accumulate(&mut acc, node, b, ez);
            kept.whole[b].write(ez);
            let (a_up, b_up) = (ua[2].simd_ge(zero), ub[2].simd_ge(zero));
            let down = ua[2].simd_le(zero) & ub[2].simd_le(zero);
            let above = (a_up & b_up).to_bitmask() as u16;
            not_above |= node.used_in_batch[b] & !above;
            let crossing = a_up ^ b_up;
            let bits = crossing.to_bitmask() as u16;
            masks[0][b] = above;
            masks[1][b] = down.to_bitmask() as u16;
            masks[2][b] = a_up.to_bitmask() as u16;
            masks[3][b] = bits;
            if bits != 0 {
                let p = horizon_points(ua, ub);
                kept.part[b].write([above_part_z(ua, ub, p, a_up), p[0], p[1]]);
            }
        },
    );
    let sums = reduce4(acc);
    if not_above == 0 {
        return sums.map(|s| child_integral(g, s));
    }
    let wide = |m: &[u16; MAX_BATCHES]| {
        (0..MAX_BATCHES).fold(0u128, |w, b| w | (m[b] as u128) << (16 * b))
    };
    let m = SlotMasks {
        above: wide(&masks[0]),
        below: wide(&masks[1]),
        a_up: wide(&masks[2]),
        crossing: wide(&masks[3]),
    };
    finish_coarse(g, node, sums, &m, &kept)
}
