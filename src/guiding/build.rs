//! Learning the directional distribution: the next iteration's sampling tree
//! from this iteration's recorded flux (Müller et al. 2017, §5.2).
//!
//! A cell whose recorded flux exceeds ρ of the total is subdivided, up to
//! [`MAX_DEPTH`]; everything else is pruned to a leaf. Where the recording
//! tree had no finer structure, the children inherit a quarter of their
//! parent's flux each, and the rule is applied again to them, so a tree can
//! deepen several levels in one rebuild around a concentrated lobe (cells
//! down to about ρ/4 of the total); the next iteration then records at that
//! finer resolution.
//!
//! The built tree stores *mean radiance* per child cell,
//! F_k / (N · Ω_k), with N the statistical weight and Ω_k = 4π/4^depth. Child
//! ratios (and hence radiance guiding) are unaffected, but the product guider
//! needs radiance so that Σ_k L_k·D_k estimates the reflected radiance.

use super::quadtree::{MAX_DEPTH, QuadNode, QuadTree};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadTreeBuilder {
    /// Subdivide a cell holding more than this fraction of the total flux.
    pub rho: f64,
    /// Deepest leaf cell, ≤ [`MAX_DEPTH`].
    pub max_depth: u32,
}

impl Default for QuadTreeBuilder {
    fn default() -> Self {
        QuadTreeBuilder {
            rho: 0.01,
            max_depth: MAX_DEPTH,
        }
    }
}

impl QuadTreeBuilder {
    /// The sampling tree learnt from `recorded`, or `None` when `recorded`
    /// holds no sample at all (the caller then keeps its previous sampling
    /// tree: old data beats none). A region that received samples which
    /// were all dark yields an all-zero tree, and the descent then reports
    /// that the guide is unavailable, which is the truth.
    pub fn build(&self, recorded: &QuadTree) -> Option<QuadTree> {
        let n = recorded.weight();
        if n <= 0.0 {
            return None;
        }
        let total = recorded.total();
        let max_depth = self.max_depth.clamp(1, MAX_DEPTH);
        let threshold = self.rho.max(0.0) * total;
        let src = recorded.nodes();
        let mut out = vec![QuadNode::default()];
        // (output node, source node if the recording resolved this cell,
        //  flux of this cell, node depth)
        let mut stack: Vec<(usize, Option<usize>, f64, u32)> = vec![(0, Some(0), total, 0)];
        while let Some((o, s, flux, depth)) = stack.pop() {
            let child_depth = depth + 1;
            let inv_norm = (1u64 << (2 * child_depth)) as f64 / (n * 4.0 * std::f64::consts::PI);
            for k in 0..4 {
                let child_flux = match s {
                    Some(s) => src[s].sums[k] as f64,
                    None => 0.25 * flux,
                };
                let radiance = child_flux * inv_norm;
                out[o].sums[k] = if radiance.is_finite() && radiance > 0.0 {
                    if radiance > f32::MAX as f64 {
                        crate::guards::record(crate::guards::GuardEvent::TreeSumSaturated, 1);
                    }
                    radiance.min(f32::MAX as f64) as f32
                } else {
                    0.0
                };
                if total > 0.0 && child_flux > threshold && child_depth < max_depth {
                    let idx = out.len();
                    out.push(QuadNode::default());
                    out[o].children[k] = idx as u32;
                    let child_src = s.and_then(|s| match src[s].children[k] {
                        0 => None,
                        c => Some(c as usize),
                    });
                    stack.push((idx, child_src, child_flux, child_depth));
                }
            }
        }
        Some(QuadTree::from_nodes(out).expect("the builder emits well-formed trees"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    #[test]
    fn splits_heavy_cells_prunes_light_ones_and_normalises_to_radiance() {
        let mut rec = QuadTree::new();
        // 99 % of the flux at one point, 1 % spread over the sphere.
        for _ in 0..99 {
            rec.record(Vec2::new(0.3, 0.3), 1.0).unwrap();
        }
        rec.record(Vec2::new(0.8, 0.8), 1.0).unwrap();
        let b = QuadTreeBuilder::default();
        let t = b.build(&rec).unwrap();
        // The depth-1 cell holds 0.99; inherited quarters keep splitting
        // while above 1 %: 0.99/4^d > 0.01 ⇔ d ≤ 3, so cells down to depth
        // 4 split and the leaves around the point are at depth 5.
        assert_eq!(t.leaf_cell(Vec2::new(0.3, 0.3)).depth, 5);
        // The 1 % cell is not above ρ and stays a leaf.
        assert_eq!(t.leaf_cell(Vec2::new(0.8, 0.8)).depth, 1);
        // Mean radiance of the light cell: 1 / (100 · π).
        let expected = 1.0 / (100.0 * std::f32::consts::PI);
        assert!((t.nodes()[0].sums[3] - expected).abs() < 1e-7);
        // Mean radiance is preserved when a cell is split by inheritance.
        let deep = t.leaf_cell(Vec2::new(0.3, 0.3));
        let mut integral = 0.0f64;
        t.for_each_leaf(|cell, i, k| {
            integral += t.nodes()[i].sums[k] as f64 * cell.solid_angle();
        });
        assert!((integral - 1.0).abs() < 1e-5, "∫L = {integral}, {deep:?}");
        assert!((t.radiance_integral() as f64 - 1.0).abs() < 1e-5);
        assert!(b.build(&QuadTree::new()).is_none());
    }

    /// One sample of 3e38 recorded into a tree resolved down to depth 5 at
    /// its point: the cells on its path hold radiance 3e38·4^d/(4π), past
    /// f32::MAX from depth 2 on. They are held at f32::MAX, finite, and
    /// every one is counted.
    #[test]
    fn radiances_past_the_largest_float_are_held_and_counted() {
        use crate::guards::{GuardEvent, thread_count};
        let p = Vec2::new(0.3, 0.3);
        let mut unit = QuadTree::new();
        for _ in 0..99 {
            unit.record(p, 1.0).unwrap();
        }
        unit.record(Vec2::new(0.8, 0.8), 1.0).unwrap();
        let mut rec = QuadTreeBuilder::default()
            .build(&unit)
            .unwrap()
            .structure_copy();
        assert_eq!(rec.leaf_cell(p).depth, 5);
        rec.record(p, 3e38).unwrap();
        let before = thread_count(GuardEvent::TreeSumSaturated);
        let t = QuadTreeBuilder::default().build(&rec).unwrap();
        let mut held = 0;
        t.for_each_leaf(|_, i, k| {
            let l = t.nodes()[i].sums[k];
            assert!(l.is_finite() && l >= 0.0, "{l}");
            held += (l == f32::MAX) as u64;
        });
        assert!(held > 0);
        // Inner cells are held too: at least every held leaf is counted.
        assert!(thread_count(GuardEvent::TreeSumSaturated) - before >= held);
    }

    #[test]
    fn respects_max_depth() {
        let mut rec = QuadTree::new();
        rec.record(Vec2::new(0.123, 0.456), 1.0).unwrap();
        let t = QuadTreeBuilder {
            rho: 0.01,
            max_depth: 3,
        }
        .build(&rec)
        .unwrap();
        assert_eq!(t.depth(), 3);
        let mut rec = t.structure_copy();
        for _ in 0..30 {
            rec.record(Vec2::new(0.123, 0.456), 1.0).unwrap();
            let _ = rec.record(Vec2::new(0.5, 0.5), f32::NAN);
        }
        let t = QuadTreeBuilder::default().build(&rec).unwrap();
        assert!(t.depth() <= MAX_DEPTH);
        // Repeated rebuilding of a point source converges to depth 20.
        let mut t = t;
        for _ in 0..10 {
            let mut rec = t.structure_copy();
            rec.record(Vec2::new(0.123, 0.456), 1.0).unwrap();
            t = QuadTreeBuilder::default().build(&rec).unwrap();
        }
        assert_eq!(t.depth(), MAX_DEPTH);
    }
}
