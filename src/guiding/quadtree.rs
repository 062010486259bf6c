//! The directional quadtree as plain data (Müller et al. 2017, §4).
//!
//! A node stands for a cell of the unit square of [`crate::directional`] and
//! stores, for each of its 4 children in the shared child order (bit 0 steps
//! in u, bit 1 in v), a sum and the index of the child's own node, or 0 when
//! the child is a leaf cell. Index 0 is the root, which is nobody's child, so
//! 0 is free to mean "leaf". The 4 siblings' sums are contiguous, so a
//! descent step reads one 16-byte vector.
//!
//! Memory: [`QuadNode`] is 32 bytes (4 × f32 sums + 4 × u32 indices); a tree
//! costs 32 bytes per node plus a fixed header, see [`QuadTree::bytes`].
//!
//! The same type plays two roles, distinguished only by what the sums mean:
//! - a *recording* tree accumulates flux, Σ value over recorded samples (the
//!   caller already divided each by its sampling pdf), so a child sum divided
//!   by the statistical weight estimates ∫_cell L dω;
//! - a *sampling* tree, produced by [`super::build::QuadTreeBuilder`], stores
//!   the mean radiance of each child cell, which is what the product guider
//!   multiplies by the cell's BSDF integral D_k.
//!
//! Learning (refinement and pruning) lives in `build.rs`; recording is here
//! because it is a pure function of the structure.

use crate::directional::Cell;
use glam::Vec2;

/// Deepest leaf cell. At depth 20 a cell spans 2^-20 of the square, which f32
/// still resolves into 16 representable positions per axis near u = 1.
pub const MAX_DEPTH: u32 = 20;

/// One node: the sums and node indices of its 4 children.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct QuadNode {
    pub sums: [f32; 4],
    /// Node index of child k, or 0 when child k is a leaf cell.
    pub children: [u32; 4],
}

/// Why a recorded value was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SplatReject {
    NonFinite,
    Negative,
}

/// Counts of values [`QuadTree::record`] refused.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SplatStats {
    pub accepted: u64,
    pub rejected_non_finite: u64,
    pub rejected_negative: u64,
}

#[derive(Clone, Debug)]
pub struct QuadTree {
    nodes: Vec<QuadNode>,
    /// Statistical weight: number of accepted samples, including zero-valued
    /// ones (a dark sample is information, and it is what the spatial split
    /// rule counts).
    weight: f64,
    stats: SplatStats,
}

impl Default for QuadTree {
    fn default() -> Self {
        Self::new()
    }
}

impl QuadTree {
    /// A root with 4 zero-sum leaf children: samples nothing (descent returns
    /// `None`) until something is recorded and built.
    pub fn new() -> Self {
        QuadTree {
            nodes: vec![QuadNode::default()],
            weight: 0.0,
            stats: SplatStats::default(),
        }
    }

    /// A root whose 4 children all hold `value`: the uniform distribution.
    pub fn uniform(value: f32) -> Self {
        let mut t = Self::new();
        t.nodes[0].sums = [value.max(0.0); 4];
        t
    }

    /// Builds a tree from explicit nodes (node 0 is the root), checking that
    /// every index is in range, that each non-root node has exactly one
    /// parent which precedes it (so there are no cycles), that no leaf cell
    /// is deeper than [`MAX_DEPTH`], and that every sum is finite and ≥ 0.
    pub fn from_nodes(nodes: Vec<QuadNode>) -> Result<Self, String> {
        if nodes.is_empty() {
            return Err("a quadtree needs a root".into());
        }
        let n = nodes.len();
        let mut parents = vec![0u32; n];
        let mut depth = vec![0u32; n];
        for (i, node) in nodes.iter().enumerate() {
            for (k, &s) in node.sums.iter().enumerate() {
                if !(s.is_finite() && s >= 0.0) {
                    return Err(format!("node {i} child {k}: sum {s} is not finite and ≥ 0"));
                }
            }
            for &c in &node.children {
                if c == 0 {
                    continue;
                }
                let c = c as usize;
                if c >= n || c <= i {
                    return Err(format!("node {i}: child index {c} out of order or range"));
                }
                parents[c] += 1;
                depth[c] = depth[i] + 1;
                // node depth d holds leaf cells at depth d+1
                if depth[c] + 1 > MAX_DEPTH {
                    return Err(format!("node {c} would hold cells deeper than {MAX_DEPTH}"));
                }
            }
        }
        if let Some(i) = (1..n).find(|&i| parents[i] != 1) {
            return Err(format!("node {i} has {} parents", parents[i]));
        }
        Ok(QuadTree {
            nodes,
            weight: 0.0,
            stats: SplatStats::default(),
        })
    }

    #[inline]
    pub fn nodes(&self) -> &[QuadNode] {
        &self.nodes
    }

    #[inline]
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Heap and inline bytes of this tree.
    pub fn bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.nodes.capacity() * std::mem::size_of::<QuadNode>()
    }

    #[inline]
    pub fn weight(&self) -> f64 {
        self.weight
    }

    #[inline]
    pub fn stats(&self) -> SplatStats {
        self.stats
    }

    /// Σ of the root's child sums.
    pub fn total(&self) -> f64 {
        self.nodes[0].sums.iter().map(|&s| s as f64).sum()
    }

    /// For a sampling tree: ∫ L dω over the sphere, Σ_k L_k·π at the root
    /// (each root child covers π sr). Radiance guiding can build an adjoint
    /// estimate for ADRRS from it.
    pub fn radiance_integral(&self) -> f32 {
        let s = self.nodes[0].sums;
        ((s[0] + s[1]) + (s[2] + s[3])) * std::f32::consts::PI
    }

    /// Same structure, zero sums and weight: the next iteration's recording
    /// tree.
    pub fn structure_copy(&self) -> Self {
        QuadTree {
            nodes: self
                .nodes
                .iter()
                .map(|n| QuadNode {
                    sums: [0.0; 4],
                    children: n.children,
                })
                .collect(),
            weight: 0.0,
            stats: SplatStats::default(),
        }
    }

    /// Scales sums and weight together, which leaves the mean-radiance
    /// estimate sum/weight unchanged (used when a spatial leaf splits).
    pub fn scale(&mut self, factor: f32) {
        let factor = if factor.is_finite() && factor >= 0.0 {
            factor
        } else {
            0.0
        };
        for n in &mut self.nodes {
            for s in &mut n.sums {
                *s *= factor;
            }
        }
        self.weight *= factor as f64;
    }

    /// Deepest leaf cell depth.
    pub fn depth(&self) -> u32 {
        let mut max = 1;
        self.for_each_leaf(|cell, _, _| max = max.max(cell.depth));
        max
    }

    /// Calls `f(leaf cell, node index, child slot)` for every leaf cell, in
    /// depth-first child order.
    pub fn for_each_leaf(&self, mut f: impl FnMut(Cell, usize, usize)) {
        let mut stack = vec![(0usize, Cell::ROOT)];
        while let Some((i, cell)) = stack.pop() {
            let node = &self.nodes[i];
            for k in 0..4 {
                let child = cell.child(k);
                match node.children[k] {
                    0 => f(child, i, k),
                    c => stack.push((c as usize, child)),
                }
            }
        }
    }

    /// The leaf cell containing `p` (points outside [0,1)² clamp to the
    /// border cells).
    pub fn leaf_cell(&self, p: Vec2) -> Cell {
        let mut idx = 0usize;
        let mut cell = Cell::ROOT;
        loop {
            let k = child_slot(cell, p);
            let child = cell.child(k);
            match self.nodes[idx].children[k] {
                0 => return child,
                c => {
                    idx = c as usize;
                    cell = child;
                }
            }
        }
    }

    fn guard(&mut self, value: f32) -> Result<(), SplatReject> {
        if !value.is_finite() {
            self.stats.rejected_non_finite += 1;
            return Err(SplatReject::NonFinite);
        }
        if value < 0.0 {
            self.stats.rejected_negative += 1;
            return Err(SplatReject::Negative);
        }
        self.stats.accepted += 1;
        self.weight += 1.0;
        Ok(())
    }

    /// Point splat: adds `value` to every sum on the path to the leaf cell
    /// containing `p`, so each node's sums stay the totals of its subtree.
    pub fn record(&mut self, p: Vec2, value: f32) -> Result<(), SplatReject> {
        self.guard(value)?;
        if value == 0.0 {
            return Ok(());
        }
        let mut idx = 0usize;
        let mut cell = Cell::ROOT;
        loop {
            let k = child_slot(cell, p);
            let node = &mut self.nodes[idx];
            node.sums[k] = saturating_add(node.sums[k], value);
            match node.children[k] {
                0 => return Ok(()),
                c => {
                    idx = c as usize;
                    cell = cell.child(k);
                }
            }
        }
    }

    /// Box-filtered splat (Müller 2017 §5.3; the 2019 notes' directional
    /// filter): spreads `value` over the box of the size of the leaf cell
    /// containing `p`, centred on `p`, in proportion to each cell's overlap.
    /// φ (v) is periodic, so the box wraps around; cos θ (u) is clipped, and
    /// the clipped part is renormalised away so the recorded total is
    /// exactly `value` (flux is neither lost at the poles nor invented).
    pub fn record_box(&mut self, p: Vec2, value: f32) -> Result<(), SplatReject> {
        self.guard(value)?;
        if value == 0.0 {
            return Ok(());
        }
        let size = 1.0 / (1u64 << self.leaf_cell(p).depth) as f64;
        let (px, py) = (p.x.clamp(0.0, 1.0) as f64, p.y.clamp(0.0, 1.0) as f64);
        let u0 = (px - 0.5 * size).max(0.0);
        let u1 = (px + 0.5 * size).min(1.0);
        let area = (u1 - u0) * size;
        if area <= 0.0 {
            return Ok(());
        }
        let density = value as f64 / area;
        let v0 = py - 0.5 * size;
        let v1 = py + 0.5 * size;
        let mut pieces = [(v0.max(0.0), v1.min(1.0)), (0.0, 0.0), (0.0, 0.0)];
        if v0 < 0.0 {
            pieces[1] = (v0 + 1.0, 1.0);
        }
        if v1 > 1.0 {
            pieces[2] = (0.0, v1 - 1.0);
        }
        for (a, b) in pieces {
            if b > a {
                self.splat_rect(0, Cell::ROOT, [u0, a, u1, b], density);
            }
        }
        Ok(())
    }

    fn splat_rect(&mut self, idx: usize, cell: Cell, rect: [f64; 4], density: f64) {
        for k in 0..4 {
            let child = cell.child(k);
            let (cu, cv, cs) = child.square_bounds();
            let w = (rect[2].min(cu + cs) - rect[0].max(cu)).max(0.0);
            let h = (rect[3].min(cv + cs) - rect[1].max(cv)).max(0.0);
            let overlap = w * h;
            if overlap <= 0.0 {
                continue;
            }
            let node = &mut self.nodes[idx];
            node.sums[k] = saturating_add(node.sums[k], (density * overlap) as f32);
            let c = node.children[k];
            if c != 0 {
                self.splat_rect(c as usize, child, rect, density);
            }
        }
    }
}

/// Which child of `cell` contains `p`, by comparison with the cell's exact
/// midlines (dyadic, so exact in f32 down to depth 20). Sampling places its
/// points with the same convention: a cell owns [lo, hi).
#[inline]
pub fn child_slot(cell: Cell, p: Vec2) -> usize {
    let half = f32::from_bits((127 - cell.depth - 1) << 23);
    let mx = (2 * cell.ix + 1) as f32 * half;
    let my = (2 * cell.iy + 1) as f32 * half;
    (p.x >= mx) as usize | (((p.y >= my) as usize) << 1)
}

/// Sums never overflow to +∞: a tree must never hold a non-finite value.
/// The flux lost by holding a sum at f32::MAX is counted.
#[inline]
fn saturating_add(a: f32, b: f32) -> f32 {
    let sum = a + b;
    if sum <= f32::MAX {
        sum
    } else {
        crate::guards::record(crate::guards::GuardEvent::TreeSumSaturated, 1);
        f32::MAX
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_level() -> QuadTree {
        let mut root = QuadNode::default();
        root.children[3] = 1;
        QuadTree::from_nodes(vec![root, QuadNode::default()]).unwrap()
    }

    #[test]
    fn node_is_32_bytes() {
        assert_eq!(std::mem::size_of::<QuadNode>(), 32);
    }

    #[test]
    fn point_record_updates_every_level_and_counts_rejects() {
        let mut t = two_level();
        t.record(Vec2::new(0.9, 0.6), 2.0).unwrap();
        assert_eq!(t.nodes()[0].sums, [0.0, 0.0, 0.0, 2.0]);
        // (0.9, 0.6) in child 3 of the root → within [0.5,1)² child (1, 0)
        assert_eq!(t.nodes()[1].sums, [0.0, 2.0, 0.0, 0.0]);
        assert_eq!(
            t.record(Vec2::new(0.1, 0.1), f32::NAN),
            Err(SplatReject::NonFinite)
        );
        assert_eq!(
            t.record(Vec2::new(0.1, 0.1), -1.0),
            Err(SplatReject::Negative)
        );
        assert_eq!(
            t.record(Vec2::new(0.1, 0.1), f32::INFINITY),
            Err(SplatReject::NonFinite)
        );
        t.record(Vec2::new(0.1, 0.1), 0.0).unwrap();
        let s = t.stats();
        assert_eq!(
            (s.accepted, s.rejected_non_finite, s.rejected_negative),
            (2, 2, 1)
        );
        assert_eq!(t.weight(), 2.0);
        assert_eq!(t.total(), 2.0);
    }

    /// Two finite values whose sum passes f32::MAX: each sum on the path is
    /// held there, and each is counted, so a tree that lost flux says so.
    #[test]
    fn sums_held_at_the_largest_float_are_counted() {
        use crate::guards::{GuardEvent, thread_count};
        let mut t = two_level();
        let before = thread_count(GuardEvent::TreeSumSaturated);
        t.record(Vec2::new(0.9, 0.6), 2e38).unwrap();
        assert_eq!(thread_count(GuardEvent::TreeSumSaturated), before);
        t.record(Vec2::new(0.9, 0.6), 2e38).unwrap();
        assert_eq!(t.nodes()[0].sums[3], f32::MAX);
        assert_eq!(t.nodes()[1].sums[1], f32::MAX);
        // The root's sum and its child's, one each.
        assert_eq!(thread_count(GuardEvent::TreeSumSaturated), before + 2);
        t.record_box(Vec2::new(0.9, 0.6), 2e38).unwrap();
        assert!(thread_count(GuardEvent::TreeSumSaturated) > before + 2);
        assert!(t.total().is_finite());
    }

    #[test]
    fn box_splat_conserves_value_and_wraps_in_phi() {
        let mut t = two_level();
        // Leaf cell of (0.2, 0.99) is a depth-1 cell of size 0.5: the box
        // spans v ∈ [0.74, 1.24], wrapping onto [0, 0.24].
        t.record_box(Vec2::new(0.2, 0.99), 1.0).unwrap();
        let s = t.nodes()[0].sums;
        assert!((t.total() - 1.0).abs() < 1e-6, "{s:?}");
        // u box [0, 0.45] after clipping at the pole lies wholly in u < 0.5
        assert_eq!(s[1], 0.0);
        assert_eq!(s[3], 0.0);
        assert!(
            (s[0] - 0.48).abs() < 1e-5 && (s[2] - 0.52).abs() < 1e-5,
            "{s:?}"
        );
        // The subtree sums match their parent's.
        let mut t = two_level();
        t.record_box(Vec2::new(0.75, 0.75), 3.0).unwrap();
        let sub: f32 = t.nodes()[1].sums.iter().sum();
        assert!((sub - t.nodes()[0].sums[3]).abs() < 1e-5);
        assert!((t.total() - 3.0).abs() < 1e-5);
    }

    #[test]
    fn from_nodes_rejects_malformed_trees() {
        let root = QuadNode {
            children: [1, 1, 0, 0],
            ..Default::default()
        };
        assert!(QuadTree::from_nodes(vec![root, QuadNode::default()]).is_err());
        let mut bad = QuadNode::default();
        bad.sums[0] = f32::NAN;
        assert!(QuadTree::from_nodes(vec![bad]).is_err());
        // A chain of 20 nodes holds leaf cells at depth 20: allowed; 21 is not.
        for (len, ok) in [(20usize, true), (21, false)] {
            let nodes: Vec<QuadNode> = (0..len)
                .map(|i| QuadNode {
                    sums: [1.0; 4],
                    children: [if i + 1 < len { i as u32 + 1 } else { 0 }, 0, 0, 0],
                })
                .collect();
            assert_eq!(QuadTree::from_nodes(nodes).is_ok(), ok, "len {len}");
        }
    }
}
