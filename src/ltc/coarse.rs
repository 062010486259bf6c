//! Children with subdivided parallels (depths 2..=5), scalar, and the parts
//! shared with the wide kernel ([`super::coarse_x16`]).
//!
//! The 4 children of such a node have 3 parallels of chords and 3
//! meridians of 2 segments between them; every edge appears once in a
//! per-node table (level 2: 102 edges instead of 4 × 34 polygon edges), its
//! two world endpoints stored as structure of arrays, padded to 16. The
//! table is built once for the 340 nodes concerned (~280 KiB), so no call
//! evaluates a sine. A kernel maps and normalises the endpoints, forms each
//! edge's z term (the only component these depths need: a child straddling
//! the horizon is clipped exactly instead of being sphere-approximated) and,
//! for edges across the horizon, the crossing point and the term of the
//! part above it. Clipping is thus per edge, independent of the child, and
//! only the horizon arcs are per child. [`finish_coarse`], shared by both
//! kernels, sums the terms, so they agree bit for bit.
//!
//! The chords span at most 1/2^P turn, where P is the lobe's plain-quad
//! depth (the first depth whose cells are a single chord wide): the API's
//! accurate default follows parallels within 1/64 turn, and a guider that
//! accepts plain quads from depth 4 gets chords of 1/16 turn at depths 2–3
//! too, a third of the edges for the same chord error.

use super::children::{GlossyLtc, child_grid};
use super::options::{EXACT_CLIP_DEPTH, FIRST_PLAIN_QUAD_DEPTH};
use super::polygon::parallel_chords;
use super::quad::{unit_cosine_vertex, unit_edge};
use crate::directional::Cell;
use glam::Vec3;
use std::ops::Range;
use std::sync::OnceLock;

/// Most edges of a node (level 2: 3 parallels × 32 chords + 6 meridian
/// segments), rounded up to whole batches of 16.
pub const MAX_EDGES: usize = 112;
/// Room for 16-wide reads from any edge of a node.
pub const EDGE_ROOM: usize = MAX_EDGES + 16;

/// The edges of one child within its node's table.
#[derive(Clone, Debug, Default)]
pub struct ChildEdges {
    /// Chords of the lower parallel, in the child's direction.
    pub lower: Range<usize>,
    /// Chords of the upper parallel (the child runs them backwards).
    pub upper: Range<usize>,
    /// Meridian segment on the child's right (forwards) and left (backwards).
    pub right: usize,
    pub left: usize,
    /// Bit e set when edge e belongs to the child (all; lower; upper chords).
    pub mask: u128,
    pub lower_mask: u128,
    pub upper_mask: u128,
}

/// Edge table of one node: endpoints a → b (x, y, z arrays, zero padded).
#[derive(Clone, Debug)]
pub struct CoarseNode {
    pub len: usize,
    pub a: [Vec<f32>; 3],
    pub b: [Vec<f32>; 3],
    pub children: [ChildEdges; 4],
}

fn build_node(cell: Cell, chord_turns: f64) -> CoarseNode {
    let depth = cell.depth + 1;
    let (z, _) = child_grid(cell);
    let span = 1.0 / (1u64 << depth) as f32;
    let v0 = 2.0 * cell.iy as f32 * span;
    // Row i: 2·n_i + 1 points spanning both children.
    let rows: Vec<Vec<Vec3>> = z
        .iter()
        .map(|&z| {
            let n = parallel_chords(depth, z as f64, chord_turns);
            let r = (1.0 - z * z).max(0.0).sqrt();
            (0..=2 * n)
                .map(|j| {
                    let (s, c) = super::polygon::sincos_turns(v0 + span * j as f32 / n as f32);
                    Vec3::new(r * c, r * s, z)
                })
                .collect()
        })
        .collect();
    let n = rows.iter().map(|r| (r.len() - 1) / 2).collect::<Vec<_>>();
    let mut edges: Vec<(Vec3, Vec3)> = Vec::new();
    let mut row_start = [0usize; 3];
    for (i, row) in rows.iter().enumerate() {
        row_start[i] = edges.len();
        edges.extend(row.windows(2).map(|w| (w[0], w[1])));
    }
    // Meridian segment (column c, between rows s and s + 1).
    let mut meridian = [[0usize; 2]; 3];
    for (c, m) in meridian.iter_mut().enumerate() {
        for (s, e) in m.iter_mut().enumerate() {
            *e = edges.len();
            edges.push((rows[s][c * n[s]], rows[s + 1][c * n[s + 1]]));
        }
    }
    let len = edges.len();
    assert!(len <= MAX_EDGES);
    let padded = len.div_ceil(16) * 16;
    let coord = |f: &dyn Fn(&(Vec3, Vec3)) -> f32| {
        let mut v: Vec<f32> = edges.iter().map(f).collect();
        v.resize(padded, 0.0);
        v
    };
    let children = std::array::from_fn(|k| {
        let (iu, iv) = (k & 1, k >> 1);
        let lower = row_start[iu] + iv * n[iu]..row_start[iu] + (iv + 1) * n[iu];
        let upper = row_start[iu + 1] + iv * n[iu + 1]..row_start[iu + 1] + (iv + 1) * n[iu + 1];
        let (right, left) = (meridian[iv + 1][iu], meridian[iv][iu]);
        let range_mask = |r: &Range<usize>| r.clone().fold(0u128, |m, e| m | 1u128 << e);
        let (lower_mask, upper_mask) = (range_mask(&lower), range_mask(&upper));
        ChildEdges {
            lower,
            upper,
            right,
            left,
            mask: lower_mask | upper_mask | (1u128 << right) | (1u128 << left),
            lower_mask,
            upper_mask,
        }
    });
    CoarseNode {
        len,
        a: [coord(&|e| e.0.x), coord(&|e| e.0.y), coord(&|e| e.0.z)],
        b: [coord(&|e| e.1.x), coord(&|e| e.1.y), coord(&|e| e.1.z)],
        children,
    }
}

/// The smallest plain-quad depth with coarse children (depth 2 is the
/// first below the exactly clipped level 1).
const FIRST_COARSE_TABLE: u32 = EXACT_CLIP_DEPTH + 2;

/// The table of a plain-quad depth P: the nodes whose children are coarse
/// (depths 1..P − 1), in level order, then iy·2^d + ix, with chords of at
/// most 1/2^P turn.
fn build_table(plain_quad_depth: u32) -> Vec<CoarseNode> {
    let chord_turns = 1.0 / (1u64 << plain_quad_depth) as f64;
    let mut v = Vec::new();
    for depth in 1..plain_quad_depth - 1 {
        let n = 1u32 << depth;
        for iy in 0..n {
            for ix in 0..n {
                v.push(build_node(Cell { depth, ix, iy }, chord_turns));
            }
        }
    }
    v
}

/// One table per plain-quad depth FIRST_COARSE_TABLE..=FIRST_PLAIN_QUAD_DEPTH,
/// each built on first use, so a run builds only the ones its options use.
const TABLE_COUNT: usize = (FIRST_PLAIN_QUAD_DEPTH - FIRST_COARSE_TABLE + 1) as usize;
static TABLES: [OnceLock<Vec<CoarseNode>>; TABLE_COUNT] = [const { OnceLock::new() }; TABLE_COUNT];

fn table(plain_quad_depth: u32) -> &'static [CoarseNode] {
    debug_assert!((FIRST_COARSE_TABLE..=FIRST_PLAIN_QUAD_DEPTH).contains(&plain_quad_depth));
    TABLES[(plain_quad_depth - FIRST_COARSE_TABLE) as usize]
        .get_or_init(|| build_table(plain_quad_depth))
}

/// Forces the table of the API's default options (others are built on
/// first use).
pub fn precompute() {
    table(FIRST_PLAIN_QUAD_DEPTH);
}

/// The edge table of a node whose children are coarse (depth 1 to
/// `plain_quad_depth` − 2).
#[inline]
pub fn coarse_node(cell: Cell, plain_quad_depth: u32) -> &'static CoarseNode {
    debug_assert!((1..plain_quad_depth - 1).contains(&cell.depth));
    let base = ((1usize << (2 * cell.depth)) - 1) / 3 - 1;
    let n = 1usize << cell.depth;
    &table(plain_quad_depth)[base + cell.iy as usize * n + cell.ix as usize]
}

/// What either kernel leaves per edge of a node (bit e of a mask is edge e).
pub struct CoarseEdges {
    /// z term of the whole edge (2π·F_z contribution, winding a → b).
    pub ez: [f32; EDGE_ROOM],
    /// z term of the part of the edge above the horizon.
    pub clip: [f32; EDGE_ROOM],
    /// Where a crossing edge meets the horizon (unit, z = 0).
    pub px: [f32; MAX_EDGES],
    pub py: [f32; MAX_EDGES],
    /// Both endpoints at z ≥ 0; both at z ≤ 0; a at z ≥ 0 (the edge
    /// crosses when this differs from b's).
    pub above: u128,
    pub below: u128,
    pub a_up: u128,
    pub crossing: u128,
}

impl CoarseEdges {
    pub fn new() -> Self {
        CoarseEdges {
            ez: [0.0; EDGE_ROOM],
            clip: [0.0; EDGE_ROOM],
            px: [0.0; MAX_EDGES],
            py: [0.0; MAX_EDGES],
            above: 0,
            below: 0,
            a_up: 0,
            crossing: 0,
        }
    }
}

impl Default for CoarseEdges {
    fn default() -> Self {
        Self::new()
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

/// Pairwise sum of the at most 16 values `t[r]` (zero padded): a fixed
/// order both kernels share (chords per child are 1, 2, 4, 8 or 16).
#[inline(always)]
fn tree_sum(t: &[f32; EDGE_ROOM], r: &Range<usize>) -> f32 {
    let w: &[f32; 16] = t[r.start..r.start + 16].try_into().unwrap();
    let len = r.len();
    let mut v: [f32; 16] = std::array::from_fn(|l| if l < len { w[l] } else { 0.0 });
    let mut w = 8;
    while w > 0 {
        for l in 0..w {
            v[l] += v[l + w];
        }
        w /= 2;
    }
    v[0]
}

/// Signed sum of a child's edge terms `t` in its winding.
#[inline]
fn child_sum(c: &ChildEdges, t: &[f32; EDGE_ROOM]) -> f32 {
    (tree_sum(t, &c.lower) + t[c.right]) - (tree_sum(t, &c.upper) + t[c.left])
}

/// The 4 child integrals from the edges: exact F_z above the horizon, 0
/// below, exact clipping across it.
pub fn finish_coarse(g: &GlossyLtc, node: &CoarseNode, e: &CoarseEdges) -> [f32; 4] {
    let scale = g.orientation * (0.5 / std::f32::consts::PI);
    std::array::from_fn(|k| {
        let c = &node.children[k];
        if e.above & c.mask == c.mask {
            (child_sum(c, &e.ez) * scale).max(0.0)
        } else if e.below & c.mask == c.mask {
            0.0
        } else {
            ((child_sum(c, &e.clip) + horizon_arcs(c, e)) * scale).max(0.0)
        }
    })
}

/// The horizon arcs of a clipped child: from each point where its boundary
/// leaves the upper half-space to the next one where it re-enters.
#[cold]
fn horizon_arcs(c: &ChildEdges, e: &CoarseEdges) -> f32 {
    // The crossing edges in the child's winding: lower chords forwards,
    // right meridian, upper chords backwards, left meridian.
    let lower = e.crossing & c.lower_mask;
    let upper = e.crossing & c.upper_mask;
    let bits = |m: u128, forward: bool| {
        let mut m = m;
        std::iter::from_fn(move || {
            (m != 0).then(|| {
                let j = if forward {
                    m.trailing_zeros()
                } else {
                    127 - m.leading_zeros()
                } as usize;
                m &= !(1u128 << j);
                (j, forward)
            })
        })
    };
    let order = bits(lower, true)
        .chain(bits(e.crossing & (1u128 << c.right), true))
        .chain(bits(upper, false))
        .chain(bits(e.crossing & (1u128 << c.left), false));
    horizon_arc_sum(order.map(|(j, forward)| {
        // Leaving when the edge's start (in the child's winding) is above.
        let exit = (e.a_up >> j & 1 == 1) == forward;
        (Vec3::new(e.px[j], e.py[j], 0.0), exit)
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

/// The 4 child integrals of a coarse node, scalar. Along a parallel each
/// edge starts where the previous one ended, so that corner is reused
/// rather than mapped again.
pub fn coarse_children_scalar(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    let node = coarse_node(cell, g.plain_quad_depth);
    let mut e = CoarseEdges::new();
    let mut prev: Option<(Vec3, Vec3)> = None;
    for j in 0..node.len {
        let wa = Vec3::new(node.a[0][j], node.a[1][j], node.a[2][j]);
        let wb = Vec3::new(node.b[0][j], node.b[1][j], node.b[2][j]);
        let ua = match prev {
            Some((w, u)) if w == wa => u,
            _ => unit_cosine_vertex(&g.rows, wa),
        };
        let ub = unit_cosine_vertex(&g.rows, wb);
        prev = Some((wb, ub));
        let (a_up, b_up) = (ua.z >= 0.0, ub.z >= 0.0);
        e.above |= ((a_up && b_up) as u128) << j;
        e.below |= ((ua.z <= 0.0 && ub.z <= 0.0) as u128) << j;
        e.a_up |= (a_up as u128) << j;
        let (c, k) = unit_edge(ua, ub);
        e.ez[j] = c.z * k;
        e.clip[j] = if a_up != b_up {
            e.crossing |= 1u128 << j;
            let p = horizon_point(ua, ub);
            (e.px[j], e.py[j]) = (p.x, p.y);
            above_part_z(ua, ub, p, a_up)
        } else if a_up {
            e.ez[j]
        } else {
            0.0
        };
    }
    finish_coarse(g, node, &e)
}
