//! Children with subdivided parallels (depths 2..=5), scalar, and the parts
//! shared with the wide kernel ([`super::coarse_x16`]).
//!
//! The 4 children of such a node have 3 parallels of chords and 3
//! meridians of 2 segments between them. A per-node table holds the chord
//! vertices of the 3 rows once, in world space (structure of arrays, whole
//! batches of 16), ordered as a snake: row 0 in increasing azimuth, row 1
//! back, row 2 forwards. Every edge is a *slot*: chord slot i runs from
//! vertex i to vertex i + 1, so the two slots where the snake turns are
//! meridian segments (the slot past the last vertex belongs to no child),
//! and the other 4 meridian segments are the first lanes of one more batch.
//! A kernel maps and normalises each vertex once (a chord's end is the
//! next lane's start), forms each slot's z term (the only component these
//! depths need: a child straddling the horizon is clipped exactly instead
//! of being sphere-approximated) and, for edges across the horizon, the
//! crossing point and the term of the part above it. Clipping is thus per
//! edge, independent of the child; only the horizon arcs are per child.
//! Each child's signed sum is one fused multiply-add per batch with the
//! child's ±1/0 slot signs, reduced in an order both kernels share
//! ([`accumulate`], [`reduce4`]), so they agree bit for bit. The tables
//! ([`super::coarse_table`]) are built once, so no call evaluates a sine.
//!
//! The chords span at most 1/2^P turn, where P is the lobe's plain-quad
//! depth (the first depth whose cells are a single chord wide): the API's
//! accurate default follows parallels within 1/64 turn, and a guider that
//! accepts plain quads from depth 4 gets chords of 1/16 turn at depths 2–3
//! too, a third of the edges for the same chord error.

use super::children::GlossyLtc;
pub use super::coarse_table::{
    ChildSlots, CoarseNode, MAX_BATCHES, MERIDIAN_ENDS, SLOT_ROOM, coarse_node, precompute,
};
use super::lanes::f32x16;
use super::quad::{unit_cosine_vertex, unit_edge};
use crate::directional::Cell;
use glam::Vec3;

/// Which slots lie wholly above the horizon (both ends at z ≥ 0), wholly
/// below it (both at z ≤ 0), start above it (a at z ≥ 0), and cross it
/// (a and b on opposite sides); bit s is slot s.
#[derive(Clone, Copy, Debug, Default)]
pub struct SlotMasks {
    pub above: u128,
    pub below: u128,
    pub a_up: u128,
    pub crossing: u128,
}

/// Per-slot terms the children across the horizon need, however a kernel
/// keeps them.
pub trait CrossingTerms {
    /// z terms of batch b's whole edges (2π·F_z contributions, a → b).
    fn whole(&self, b: usize) -> f32x16;
    /// z terms of the parts above the horizon of batch b's crossing edges
    /// (asked only of batches with one).
    fn part(&self, b: usize) -> f32x16;
    /// Where crossing slot j meets the horizon (unit, z = 0).
    fn point(&self, j: usize) -> Vec3;
}

/// The scalar kernel's per-slot terms.
pub struct SlotTerms {
    pub ez: [f32; SLOT_ROOM],
    pub part: [f32; SLOT_ROOM],
    pub px: [f32; SLOT_ROOM],
    pub py: [f32; SLOT_ROOM],
    pub masks: SlotMasks,
}

impl SlotTerms {
    pub fn new() -> Self {
        SlotTerms {
            ez: [0.0; SLOT_ROOM],
            part: [0.0; SLOT_ROOM],
            px: [0.0; SLOT_ROOM],
            py: [0.0; SLOT_ROOM],
            masks: SlotMasks::default(),
        }
    }
}

impl Default for SlotTerms {
    fn default() -> Self {
        Self::new()
    }
}

impl CrossingTerms for SlotTerms {
    fn whole(&self, b: usize) -> f32x16 {
        super::simd::load16(&self.ez, 16 * b)
    }

    fn part(&self, b: usize) -> f32x16 {
        super::simd::load16(&self.part, 16 * b)
    }

    fn point(&self, j: usize) -> Vec3 {
        Vec3::new(self.px[j], self.py[j], 0.0)
    }
}

/// Where the great arc a → b (unit, z of opposite signs) meets z = 0,
/// normalised; [`super::simd::horizon_points`] is its lane-wise twin.
#[inline(always)]
pub fn horizon_point(a: Vec3, b: Vec3) -> Vec3 {
    let t = a.z / (a.z - b.z);
    let x = (b.x - a.x).mul_add(t, a.x);
    let y = (b.y - a.y).mul_add(t, a.y);
    let inv = super::fast_math::rsqrt(y.mul_add(y, x * x).max(super::fast_math::RSQRT_FLOOR));
    Vec3::new(x * inv, y * inv, 0.0)
}

/// Adds batch `b` of slot terms `v` into the 4 children's accumulators,
/// each term times the child's sign of its slot (exact: ±1 or 0). The
/// order of the batches is the order of the sums, which both kernels share.
#[inline(always)]
pub fn accumulate(acc: &mut [f32x16; 4], node: &CoarseNode, b: usize, v: f32x16) {
    for (a, sign) in acc.iter_mut().zip(&node.signs[b]) {
        *a = v.mul_add(*sign, *a);
    }
}

/// The 4 accumulators' lane sums, in a fixed order.
#[inline(always)]
pub fn reduce4(acc: [f32x16; 4]) -> [f32; 4] {
    super::simd::lane_sums4(acc).to_array()
}

/// A child's integral from its signed edge sum.
#[inline(always)]
pub fn child_integral(g: &GlossyLtc, sum: f32) -> f32 {
    (sum * (g.orientation * (0.5 / std::f32::consts::PI))).max(0.0)
}

/// The 4 child integrals from their signed sums of whole edges: exact F_z
/// above the horizon, 0 below, exact clipping across it.
#[inline(always)]
pub fn finish_coarse(
    g: &GlossyLtc,
    node: &CoarseNode,
    sums: [f32; 4],
    m: &SlotMasks,
    terms: &impl CrossingTerms,
) -> [f32; 4] {
    let status = node.children.each_ref().map(|c| {
        if m.above & c.mask == c.mask {
            Some(true)
        } else if m.below & c.mask == c.mask {
            Some(false)
        } else {
            None
        }
    });
    if status.iter().all(Option::is_some) {
        return std::array::from_fn(|k| {
            if status[k] == Some(true) {
                child_integral(g, sums[k])
            } else {
                0.0
            }
        });
    }
    clipped_children(g, node, sums, m, terms, status)
}

/// [`finish_coarse`] with a child across the horizon: the sums of the
/// edges' parts above the horizon (whole terms above, nothing below, the
/// part of a crossing edge), closed by the horizon arcs.
#[cold]
#[inline(never)]
fn clipped_children(
    g: &GlossyLtc,
    node: &CoarseNode,
    sums: [f32; 4],
    m: &SlotMasks,
    terms: &impl CrossingTerms,
    status: [Option<bool>; 4],
) -> [f32; 4] {
    let mut acc = [f32x16::splat(0.0); 4];
    for b in 0..node.batches() {
        let lanes = |mask: u128| super::simd::lane_mask((mask >> (16 * b)) as u16);
        let above = lanes(m.above).bitselect(terms.whole(b), f32x16::splat(0.0));
        let crossing = (m.crossing >> (16 * b)) as u16;
        let clipped = if crossing != 0 {
            lanes(m.crossing).bitselect(terms.part(b), above)
        } else {
            above
        };
        accumulate(&mut acc, node, b, clipped);
    }
    let clipped = reduce4(acc);
    std::array::from_fn(|k| match status[k] {
        Some(true) => child_integral(g, sums[k]),
        Some(false) => 0.0,
        None => child_integral(g, clipped[k] + horizon_arcs(&node.children[k], m, terms)),
    })
}

/// The horizon arcs of a clipped child: from each point where its boundary
/// leaves the upper half-space to the next one where it re-enters.
fn horizon_arcs(c: &ChildSlots, m: &SlotMasks, terms: &impl CrossingTerms) -> f32 {
    // The child's crossing slots in its winding.
    let crossings = c.parts.iter().flat_map(|&(slots, forward)| {
        let mut bits = m.crossing & slots;
        std::iter::from_fn(move || {
            (bits != 0).then(|| {
                let j = if forward {
                    bits.trailing_zeros()
                } else {
                    127 - bits.leading_zeros()
                } as usize;
                bits &= !(1u128 << j);
                (j, forward)
            })
        })
    });
    horizon_arc_sum(crossings.map(|(j, forward)| {
        // Leaving when the edge's start (in the child's winding) is above.
        let exit = (m.a_up >> j & 1 == 1) == forward;
        (terms.point(j), exit)
    }))
}

/// z term of the part above the horizon of an edge a → b that crosses it
/// at p: a → p when a is up, p → b otherwise.
#[inline]
pub fn above_part_z(ua: Vec3, ub: Vec3, p: Vec3, a_up: bool) -> f32 {
    let (c, k) = if a_up {
        unit_edge(ua, p)
    } else {
        unit_edge(p, ub)
    };
    c.z * k
}

/// Given a clipped boundary's horizon crossings in winding order, each a
/// point and whether the boundary leaves the upper half-space there, the
/// z terms of the horizon arcs that close it: from each exit to the next
/// entry, the last exit wrapping around to the first entry.
pub fn horizon_arc_sum(crossings: impl Iterator<Item = (Vec3, bool)>) -> f32 {
    let arc = |q: Vec3, p: Vec3| {
        let (c, k) = unit_edge(q, p);
        c.z * k
    };
    let mut sum = 0.0f32;
    let mut pending_exit: Option<Vec3> = None;
    let mut first_entry: Option<Vec3> = None;
    for (p, exit) in crossings {
        if exit {
            pending_exit = Some(p);
        } else {
            match pending_exit.take() {
                Some(q) => sum += arc(q, p),
                None => first_entry = first_entry.or(Some(p)),
            }
        }
    }
    if let (Some(q), Some(p)) = (pending_exit, first_entry) {
        sum += arc(q, p);
    }
    sum
}

/// Records slot `j`, the edge between unit vectors `ua` → `ub`.
fn record_slot(e: &mut SlotTerms, j: usize, ua: Vec3, ub: Vec3) {
    let (a_up, b_up) = (ua.z >= 0.0, ub.z >= 0.0);
    let m = &mut e.masks;
    m.above |= ((a_up && b_up) as u128) << j;
    m.below |= ((ua.z <= 0.0 && ub.z <= 0.0) as u128) << j;
    m.a_up |= (a_up as u128) << j;
    let (c, k) = unit_edge(ua, ub);
    e.ez[j] = c.z * k;
    if a_up != b_up {
        m.crossing |= 1u128 << j;
        let p = horizon_point(ua, ub);
        (e.px[j], e.py[j]) = (p.x, p.y);
        e.part[j] = above_part_z(ua, ub, p, a_up);
    }
}

/// The 4 child integrals of a coarse node, scalar: every vertex mapped
/// once, every child's slot from its two unit vertices.
pub fn coarse_children_scalar(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    let node = coarse_node(cell, g.plain_quad_depth);
    let mut e = SlotTerms::new();
    let mut u = [Vec3::ZERO; SLOT_ROOM];
    for (i, v) in u[..node.vertex_count].iter_mut().enumerate() {
        let b = &node.vertices[i / 16];
        let l = i % 16;
        *v = unit_cosine_vertex(&g.rows, Vec3::new(b[0][l], b[1][l], b[2][l]));
    }
    // Only the children's slots: the others have sign 0 in every sum.
    let meridians = node.meridian_slot(0);
    let mut slots = node.used;
    while slots != 0 {
        let j = slots.trailing_zeros() as usize;
        slots &= slots - 1;
        let (a, b) = if j < meridians {
            (j, j + 1)
        } else {
            let l = j - meridians;
            (
                node.meridian_start[l] as usize,
                node.meridian_end[l] as usize,
            )
        };
        record_slot(&mut e, j, u[a], u[b]);
    }
    let mut acc = [f32x16::splat(0.0); 4];
    for b in 0..node.batches() {
        accumulate(&mut acc, node, b, e.whole(b));
    }
    finish_coarse(g, node, reduce4(acc), &e.masks, &e)
}
