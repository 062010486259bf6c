//! The slot tables of the coarse kernels ([`super::coarse`]): per node
//! whose children have subdivided parallels, the chord vertices in world
//! space along the snake through the 3 rows, the meridians off the snake,
//! and each child's slots with their signs. One table per plain-quad
//! depth, built on first use.

use super::children::child_grid;
use super::lanes::f32x16;
use super::options::{EXACT_CLIP_DEPTH, FIRST_PLAIN_QUAD_DEPTH};
use super::polygon::parallel_chords;
use crate::directional::Cell;
use glam::Vec3;
use std::sync::OnceLock;

/// Most slots of a node: chord vertices in whole batches (at most 51, 3
/// rows of 17 at level 3 and 1/64 turn; level 2 has 3 + 33 + 3), and one
/// batch of meridians, so a node's slots fit the bits of a u128.
pub const SLOT_ROOM: usize = 128;
/// Most batches of 16 slots.
pub const MAX_BATCHES: usize = SLOT_ROOM / 16;

/// The edges of one child within its node's slots.
#[derive(Clone, Debug, Default)]
pub struct ChildSlots {
    /// The child's boundary in its winding (lower chords, right meridian,
    /// upper chords, left meridian): each part's slots, and whether the
    /// child runs them in their own direction (then in ascending slot
    /// order) or against it (then descending).
    pub parts: [(u128, bool); 4],
    /// Bit s set when slot s belongs to the child.
    pub mask: u128,
}

/// Slot table of one node. The chord vertices snake through the rows
/// (row 0 in increasing azimuth, row 1 back, row 2 forwards), so the two
/// slots that join rows are meridians of the children (the right end of
/// rows 0–1, the left end of rows 1–2); the other 4 meridians are the
/// slots of one more batch.
#[derive(Clone, Debug)]
pub struct CoarseNode {
    /// World chord vertices, batch by batch: x, y, z of 16 vertices (zero
    /// padded past the last).
    pub vertices: Vec<[[f32; 16]; 3]>,
    pub vertex_count: usize,
    /// World endpoints of the other 4 meridians (upwards): starts in lanes
    /// 0..4, ends in lanes [`MERIDIAN_END_LANE`]..+4.
    pub meridians: [[f32; 16]; 3],
    /// The same meridians as chord vertex indices, start and end, per lane
    /// of the meridian batch (0 past the fourth).
    pub meridian_start: [i32; 16],
    pub meridian_end: [i32; 16],
    pub children: [ChildSlots; 4],
    /// Per batch, each child's sign of each slot: +1 where the child runs
    /// it in its direction, −1 against it, 0 where it is not the child's.
    pub signs: Vec<[f32x16; 4]>,
    /// The slots of all 4 children, as a whole and per batch.
    pub used: u128,
    pub used_in_batch: [u16; MAX_BATCHES],
}

impl CoarseNode {
    /// Batches of slots: the chord batches, then the meridians'.
    #[inline(always)]
    pub fn batches(&self) -> usize {
        self.vertices.len() + 1
    }

    /// The slot of lane l of the meridian batch.
    #[inline(always)]
    pub fn meridian_slot(&self, l: usize) -> usize {
        16 * self.vertices.len() + l
    }
}

/// Lane of the meridian batch holding meridian m's end (m < 4).
pub const MERIDIAN_END_LANE: usize = 8;

fn build_node(cell: Cell, chord_turns: f64) -> CoarseNode {
    let depth = cell.depth + 1;
    let (z, _) = child_grid(cell);
    let span = 1.0 / (1u64 << depth) as f32;
    let v0 = 2.0 * cell.iy as f32 * span;
    // Row i: 2·n_i + 1 points spanning both children, in increasing azimuth.
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
    let len: Vec<usize> = rows.iter().map(|r| r.len()).collect();
    let n: Vec<usize> = len.iter().map(|l| (l - 1) / 2).collect();
    // Vertex index of point j (in azimuth order) of row r, along the snake.
    let vertex = |r: usize, j: usize| match r {
        0 => j,
        1 => len[0] + len[1] - 1 - j,
        _ => len[0] + len[1] + j,
    };
    let mut points = vec![Vec3::ZERO; len.iter().sum()];
    for (r, row) in rows.iter().enumerate() {
        for (j, p) in row.iter().enumerate() {
            points[vertex(r, j)] = *p;
        }
    }
    let batches = points.len().div_ceil(16);
    assert!(
        16 * (batches + 1) <= SLOT_ROOM,
        "{cell:?}: {} chord vertices",
        points.len()
    );
    let vertices = (0..batches)
        .map(|b| {
            let at = |l: usize| points.get(16 * b + l).copied().unwrap_or(Vec3::ZERO);
            [
                std::array::from_fn(|l| at(l).x),
                std::array::from_fn(|l| at(l).y),
                std::array::from_fn(|l| at(l).z),
            ]
        })
        .collect();
    // Chord between points j and j + 1 of row r: its slot, and whether the
    // slot runs in increasing azimuth.
    let chord = |r: usize, j: usize| {
        let (a, b) = (vertex(r, j), vertex(r, j + 1));
        (a.min(b), a < b)
    };
    // Meridian (column c, segment s) upwards from row s: its slot, the
    // chord slot that joins the rows where the snake turns, else a lane of
    // the meridian batch.
    let mut extra = Vec::new();
    let mut meridian_slots = [[0usize; 2]; 3];
    for (c, slots) in meridian_slots.iter_mut().enumerate() {
        for (s, slot) in slots.iter_mut().enumerate() {
            let (a, b) = (vertex(s, c * n[s]), vertex(s + 1, c * n[s + 1]));
            *slot = if b == a + 1 {
                a
            } else {
                extra.push((a, b));
                16 * batches + extra.len() - 1
            };
        }
    }
    let meridian = |c: usize, s: usize| meridian_slots[c][s];
    let parts: [[(Vec<usize>, bool); 4]; 4] = std::array::from_fn(|k| {
        let (iu, iv) = (k & 1, k >> 1);
        let lower: Vec<(usize, bool)> = (iv * n[iu]..(iv + 1) * n[iu])
            .map(|j| chord(iu, j))
            .collect();
        let upper: Vec<(usize, bool)> = (iv * n[iu + 1]..(iv + 1) * n[iu + 1])
            .map(|j| chord(iu + 1, j))
            .collect();
        // A row's chords all run one way; lower ones are walked in
        // increasing azimuth, upper ones in decreasing.
        let same = |c: &[(usize, bool)], increasing: bool| c[0].1 == increasing;
        [
            (lower.iter().map(|c| c.0).collect(), same(&lower, true)),
            (vec![meridian(iv + 1, iu)], true),
            (upper.iter().map(|c| c.0).collect(), same(&upper, false)),
            (vec![meridian(iv, iu)], false),
        ]
    });
    assert_eq!(extra.len(), 4, "{cell:?}: meridians off the snake");
    let mut meridians = [[0.0f32; 16]; 3];
    let (mut meridian_start, mut meridian_end) = ([0i32; 16], [0i32; 16]);
    for (m, &(a, b)) in extra.iter().enumerate() {
        (meridian_start[m], meridian_end[m]) = (a as i32, b as i32);
        for (axis, plane) in meridians.iter_mut().enumerate() {
            plane[m] = points[a][axis];
            plane[MERIDIAN_END_LANE + m] = points[b][axis];
        }
    }
    let children = parts.map(|parts| {
        let bits = |slots: &[usize]| slots.iter().fold(0u128, |m, &s| m | 1u128 << s);
        let parts = parts.map(|(slots, same)| (bits(&slots), same));
        ChildSlots {
            parts,
            mask: parts.iter().fold(0, |m, p| m | p.0),
        }
    });
    let signs = (0..=batches)
        .map(|b| {
            children.each_ref().map(|c| {
                f32x16::from(std::array::from_fn::<f32, 16, _>(|l| {
                    let j = 16 * b + l;
                    match c.parts.iter().find(|p| p.0 >> j & 1 == 1) {
                        Some(&(_, true)) => 1.0,
                        Some(&(_, false)) => -1.0,
                        None => 0.0,
                    }
                }))
            })
        })
        .collect();
    let used = children.iter().fold(0, |m, c| m | c.mask);
    CoarseNode {
        vertex_count: points.len(),
        signs,
        used,
        used_in_batch: std::array::from_fn(|b| (used >> (16 * b)) as u16),
        vertices,
        meridians,
        meridian_start,
        meridian_end,
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

/// For each lane of the meridian batch built from world endpoints, the
/// lane holding its edge's end (meridian m: lane m → lane m +
/// [`MERIDIAN_END_LANE`]; the other lanes' edges belong to no child).
pub const MERIDIAN_ENDS: [i32; 16] = {
    let mut t = [0i32; 16];
    let mut l = 0;
    while l < 16 {
        t[l] = ((l + MERIDIAN_END_LANE) % 16) as i32;
        l += 1;
    }
    t
};

#[cfg(test)]
mod tests {
    use super::*;

    /// Every child's parts, walked in its winding and direction, join end
    /// to start, close counter-clockwise, and the sign vectors agree with
    /// the parts.
    #[test]
    fn children_are_closed_loops_of_slots() {
        for plain_quad_depth in FIRST_COARSE_TABLE..=FIRST_PLAIN_QUAD_DEPTH {
            for node in table(plain_quad_depth) {
                let world = |i: usize| {
                    let b = &node.vertices[i / 16];
                    Vec3::new(b[0][i % 16], b[1][i % 16], b[2][i % 16])
                };
                let ends = |j: usize| {
                    let first = node.meridian_slot(0);
                    if j < first {
                        assert!(j + 1 < node.vertex_count);
                        (world(j), world(j + 1))
                    } else {
                        let l = j - first;
                        assert!(l < 4, "meridian lane {l}");
                        let (a, b) = (node.meridian_start[l], node.meridian_end[l]);
                        (world(a as usize), world(b as usize))
                    }
                };
                for (k, c) in node.children.iter().enumerate() {
                    let mut walk = Vec::new();
                    for &(slots, forward) in &c.parts {
                        assert_ne!(slots, 0);
                        let mut js: Vec<usize> =
                            (0..128).filter(|&j| slots >> j & 1 == 1).collect();
                        if !forward {
                            js.reverse();
                        }
                        for j in js {
                            let (a, b) = ends(j);
                            walk.push(if forward { (a, b) } else { (b, a) });
                            let sign = node.signs[j / 16][k].as_array()[j % 16];
                            assert_eq!(sign, if forward { 1.0 } else { -1.0 });
                        }
                    }
                    for (i, e) in walk.iter().enumerate() {
                        let next = walk[(i + 1) % walk.len()];
                        assert_eq!(e.1, next.0, "{i} of {}", walk.len());
                    }
                    // Counter-clockwise seen from outside, as the kernels'
                    // sign convention needs.
                    let centre: Vec3 = walk.iter().map(|e| e.0).sum();
                    let turning: f32 = walk.iter().map(|e| e.0.cross(e.1).dot(centre)).sum();
                    assert!(turning > 0.0, "child {k} winds clockwise");
                    let signed = (0..16 * node.batches())
                        .filter(|&j| node.signs[j / 16][k].as_array()[j % 16] != 0.0)
                        .count();
                    assert_eq!(signed, walk.len());
                }
            }
        }
    }
}
