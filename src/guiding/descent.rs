//! One descent for sampling and pdf evaluation (DESIGN §4).
//!
//! Both walk the tree from the root; at every node they ask a
//! [`ChildWeights`] for the 4 children's weights and turn them into a child
//! probability with the same function ([`resolve`] then [`step_pdf`]), so for
//! a given shading point the pdf of a sampled point is bit-identical to the
//! pdf returned by sampling. The square-measure pdf is
//! ∏_levels 4·w_k/Σ_j w_j, uniform inside the leaf cell.
//!
//! Sampling rescales one 2D sample down the tree (Open PGL style): at each
//! level u.x picks the column (u marginal), u.y the row within the column
//! (conditional), and both are stretched back to [0,1), so a stratified
//! input stays stratified at every level.
//!
//! Fallback: weights that are non-finite (counted as
//! [`GuardEvent::DescentWeightsNonfinite`]), or all zero below a parent that
//! had weight, are replaced by the radiance sums at that level, and if those are
//! zero too by the uniform split. Only a zero (or unusable) root means the
//! guide has nothing to offer: `sample` returns `None` and `pdf` 0, and the
//! caller samples the BSDF alone.

use super::quadtree::{QuadNode, QuadTree, child_slot};
use crate::directional::{Cell, SQUARE_TO_SOLID_ANGLE_PDF, dir_to_square, square_to_dir};
use crate::guards::{GuardEvent, record};
use glam::{Vec2, Vec3};

/// The per-vertex view of the tree: radiance guiding returns the radiance
/// unchanged, product guiding multiplies each by the child cell's BSDF
/// integral. Implementations may cache per-vertex work behind `&mut self`;
/// the descent calls it once per visited node, parents before children.
pub trait ChildWeights {
    /// Weights of the 4 children of `cell`, given their stored radiance sums
    /// (radiance guiding returns `radiance` unchanged; product guiding
    /// returns radiance[k]·D_k).
    fn child_weights(&mut self, cell: Cell, radiance: [f32; 4]) -> [f32; 4];

    /// Depth down to which the descent continues *below* the tree's leaves,
    /// giving the four sub-cells the leaf's radiance: product guiding's BSDF
    /// factor still varies inside a leaf, and a glossy lobe narrower than
    /// the leaf would otherwise be sampled uniformly over the whole leaf.
    /// 0 (radiance guiding): stop at the leaves.
    fn refine_below_leaves_to(&self) -> u32 {
        0
    }

    /// True when these weights are the stored radiance at this vertex
    /// (w_k = L_k, no refinement below the leaves), as [`RadianceWeights`]
    /// are: [`sample`], [`pdf`] and [`root_total`] then descend with
    /// `RadianceWeights` itself, whose code is specialised to that, so
    /// sample and pdf stay the same functions of the tree.
    fn is_radiance(&self) -> bool {
        false
    }
}

/// Below the leaves, the descent stops once the largest sub-cell weight is
/// within this factor of the smallest: sampling the cell uniformly then
/// costs little variance, and each further level costs an LTC evaluation.
const VIRTUAL_UNIFORM_RATIO: f32 = 1.5;

/// Below the leaves, the descent also stops in cells holding less than this
/// probability: they are rarely visited, and refining them buys nothing.
const VIRTUAL_MIN_MASS: f32 = 1e-3;

/// Probability mass of a cell reached with square-measure pdf `pdf`.
#[inline]
fn cell_mass(pdf: f32, cell: Cell) -> f32 {
    pdf * f32::from_bits((127 - 2 * cell.depth) << 23)
}

#[inline]
fn nearly_uniform(w: [f32; 4]) -> bool {
    let max = w[0].max(w[1]).max(w[2].max(w[3]));
    let min = w[0].min(w[1]).min(w[2].min(w[3]));
    max <= VIRTUAL_UNIFORM_RATIO * min
}

/// Radiance-only guiding: w_k = L_k.
#[derive(Clone, Copy, Debug, Default)]
pub struct RadianceWeights;

impl ChildWeights for RadianceWeights {
    #[inline]
    fn child_weights(&mut self, _cell: Cell, radiance: [f32; 4]) -> [f32; 4] {
        radiance
    }

    fn is_radiance(&self) -> bool {
        true
    }
}

impl<W: ChildWeights + ?Sized> ChildWeights for &mut W {
    #[inline]
    fn child_weights(&mut self, cell: Cell, radiance: [f32; 4]) -> [f32; 4] {
        (**self).child_weights(cell, radiance)
    }

    fn refine_below_leaves_to(&self) -> u32 {
        (**self).refine_below_leaves_to()
    }

    fn is_radiance(&self) -> bool {
        (**self).is_radiance()
    }
}

/// Result of a descent from the sampling side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Descended {
    /// Point of the unit square, inside the chosen leaf cell.
    pub point: Vec2,
    /// Density with respect to area on the square.
    pub pdf_square: f32,
    /// Σ_k w_k at the root as the weight function returned it, or 0 when
    /// the root's weights were unusable and the radiance fallback took over.
    /// For product guiding this is Σ L_k·D_k, the reflected-radiance
    /// (adjoint) estimate ADRRS needs.
    pub root_total: f32,
}

/// Largest f32 below 1: a rescaled sample must stay in [0, 1).
pub(crate) const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

/// The weights with negatives (approximation noise) clamped to 0, and
/// their total: NaN when a weight is not finite, ∞ when the sum overflows.
#[inline(always)]
fn clamped_total(w: [f32; 4]) -> ([f32; 4], f32) {
    if !(w[0].is_finite() && w[1].is_finite() && w[2].is_finite() && w[3].is_finite()) {
        return (w, f32::NAN);
    }
    let w = w.map(|x| if x > 0.0 { x } else { 0.0 });
    (w, (w[0] + w[1]) + (w[2] + w[3]))
}

/// Weights usable as probabilities: all finite, negatives clamped to 0,
/// positive finite total.
#[inline]
fn sanitize(w: [f32; 4]) -> Option<([f32; 4], f32)> {
    let (w, total) = clamped_total(w);
    (total > 0.0 && total.is_finite()).then_some((w, total))
}

/// The weights used at one node, with their total, and the root total to
/// report. `None` only at the root.
///
/// Always inlined: with product weights the compiler had kept it a call
/// per level, its result returned through memory and the caller's
/// registers saved around it; inlined, product-guided renders of staircase
/// take 4 % (without NEE) and 1.6 % (with NEE) less CPU time, on average
/// over 6 side-by-side runs each (identical images; radiance weights were
/// inlined already).
#[inline(always)]
fn resolve<W: ChildWeights>(
    weights: &mut W,
    cell: Cell,
    radiance: [f32; 4],
) -> Option<([f32; 4], f32, f32)> {
    let (w, t) = clamped_total(weights.child_weights(cell, radiance));
    if t > 0.0 && t.is_finite() {
        return Some((w, t, t));
    }
    // The root's own guard is the caller's (it sees the root total); below
    // it, a NaN or Inf is replaced here and must not pass uncounted.
    if !t.is_finite() && cell.depth > 0 {
        record(GuardEvent::DescentWeightsNonfinite, 1);
    }
    if let Some((w, t)) = sanitize(radiance) {
        return Some((w, t, 0.0));
    }
    if cell.depth == 0 {
        None
    } else {
        Some(([1.0; 4], 4.0, 0.0))
    }
}

/// The pdf update for child weight `w` of total `total`; the single place
/// where it is computed, so sample and pdf round identically.
#[inline(always)]
fn step_pdf(pdf: f32, w: f32, total: f32) -> f32 {
    pdf * ((w / total) * 4.0)
}

/// Chooses side 1 with probability b/(a+b) (a+b > 0) and rescales `u` to
/// the chosen side. The choice is data, not control flow: with random `u`
/// a branch would mispredict half the time, twice per level. The choice
/// compares u·(a+b) with a (no division on the u-dependency chain), and the
/// reciprocals depend only on the weights, so they overlap that chain. A
/// side of zero weight is never chosen (its reciprocal may be ∞ but is then
/// not selected).
#[inline(always)]
fn split(u: f32, a: f32, b: f32) -> (usize, f32) {
    let scaled = u * (a + b);
    let (inv_a, inv_b) = (1.0 / a, 1.0 / b);
    // u < 1, but u·(a+b) may still round up to a when b = 0.
    let side = (scaled >= a && b > 0.0) as usize;
    let (offset, inv) = if side == 0 { (0.0, inv_a) } else { (a, inv_b) };
    (side, (scaled - offset) * inv)
}

/// One level of the 2D descent: the column from u.x with the marginal, the
/// row from u.y within that column. Both columns' row splits are computed
/// before the column is known, so the two splits run side by side instead
/// of one after the other.
#[inline(always)]
fn choose_child(u: Vec2, w: [f32; 4]) -> (usize, Vec2) {
    let (bx, ux) = split(u.x, w[0] + w[2], w[1] + w[3]);
    let rows = [split(u.y, w[0], w[2]), split(u.y, w[1], w[3])];
    let (by, uy) = rows[bx];
    (bx | (by << 1), Vec2::new(ux, uy))
}

#[inline]
fn cell_point(cell: Cell, r: Vec2) -> Vec2 {
    let size = cell.square_size();
    let axis = |i: u32, r: f32| {
        let lo = i as f32 * size;
        let hi = (i + 1) as f32 * size;
        let p = lo + r * size;
        // Rounding may land on the upper edge, which belongs to the
        // neighbour; pull it back inside so pdf() retraces this path.
        if p >= hi { hi.next_down() } else { p.max(lo) }
    };
    Vec2::new(axis(cell.ix, r.x), axis(cell.iy, r.y))
}

/// Samples the tree with one 2D sample `u` ∈ [0,1)².
pub fn sample_descend<W: ChildWeights>(
    tree: &QuadTree,
    weights: &mut W,
    u: Vec2,
) -> Option<Descended> {
    let nodes = tree.nodes();
    let clamp = |x: f32| if x >= 0.0 { x.min(ONE_MINUS_EPS) } else { 0.0 };
    let mut u = Vec2::new(clamp(u.x), clamp(u.y));
    let refine_to = weights.refine_below_leaves_to();
    // `node` is None below the tree's leaves, where `sums` replicate the
    // leaf's radiance.
    let mut node = Some(0usize);
    let mut sums = nodes.first()?.sums;
    prefetch_children(nodes, &nodes[0]);
    let mut cell = Cell::ROOT;
    let mut pdf = 1.0f32;
    let mut root_total = 0.0;
    loop {
        let (w, total, reported) = resolve(weights, cell, sums)?;
        if cell.depth == 0 {
            root_total = reported;
        }
        if node.is_none() && (nearly_uniform(w) || cell_mass(pdf, cell) < VIRTUAL_MIN_MASS) {
            return Some(Descended {
                point: cell_point(cell, u),
                pdf_square: pdf,
                root_total,
            });
        }
        let (k, r) = choose_child(u, w);
        // The clamp also maps the NaN of 0·∞ (a subnormal weight chosen by
        // u = 0) to 0.
        u = Vec2::new(clamp(r.x), clamp(r.y));
        pdf = step_pdf(pdf, w[k], total);
        let child = cell.child(k);
        match node.map_or(0, |i| nodes[i].children[k]) {
            0 if child.depth < refine_to => {
                sums = [sums[k]; 4];
                node = None;
                cell = child;
            }
            0 => {
                return Some(Descended {
                    point: cell_point(child, u),
                    pdf_square: pdf,
                    root_total,
                });
            }
            c => {
                node = Some(c as usize);
                sums = nodes[c as usize].sums;
                prefetch_children(nodes, &nodes[c as usize]);
                cell = child;
            }
        }
    }
}

/// Starts loading the nodes of `node`'s children. Which child the sample
/// descent takes depends on the weights, and its node is a cache miss on a
/// large tree: requested as soon as the parent arrives, the miss overlaps
/// the weights (an LTC integral for the product) and the choice, instead
/// of following them.
#[inline(always)]
fn prefetch_children(nodes: &[QuadNode], node: &QuadNode) {
    for &c in &node.children {
        if let Some(child) = nodes.get(c as usize).filter(|_| c != 0) {
            crate::huge::prefetch(child);
        }
    }
}

/// Square-measure pdf of `p` and the root total, walking the path `sample`
/// would take to `p`.
pub fn pdf_descend<W: ChildWeights>(tree: &QuadTree, weights: &mut W, p: Vec2) -> (f32, f32) {
    if !(p.x.is_finite() && p.y.is_finite()) {
        return (0.0, 0.0);
    }
    let nodes = tree.nodes();
    let Some(first) = nodes.first() else {
        return (0.0, 0.0);
    };
    let refine_to = weights.refine_below_leaves_to();
    let mut node = Some(0usize);
    let mut sums = first.sums;
    let mut cell = Cell::ROOT;
    let mut pdf = 1.0f32;
    let mut root_total = 0.0;
    loop {
        let Some((w, total, reported)) = resolve(weights, cell, sums) else {
            return (0.0, 0.0);
        };
        if cell.depth == 0 {
            root_total = reported;
        }
        if node.is_none() && (nearly_uniform(w) || cell_mass(pdf, cell) < VIRTUAL_MIN_MASS) {
            return (pdf, root_total);
        }
        let k = child_slot(cell, p);
        if w[k] == 0.0 {
            return (0.0, root_total);
        }
        pdf = step_pdf(pdf, w[k], total);
        let child = cell.child(k);
        match node.map_or(0, |i| nodes[i].children[k]) {
            0 if child.depth < refine_to => {
                sums = [sums[k]; 4];
                node = None;
                cell = child;
            }
            0 => return (pdf, root_total),
            c => {
                node = Some(c as usize);
                sums = nodes[c as usize].sums;
                cell = child;
            }
        }
    }
}

/// Calls `f(cell, probability)` for every terminal cell of the
/// distribution (a leaf of the tree, or where the descent stops below one),
/// with the probability that `sample` ends there. The probabilities sum to 1
/// (or the root is unusable and nothing is reported). For tests: the exact
/// bin probabilities of a χ² test, and normalisation.
pub fn for_each_terminal_cell<W: ChildWeights>(
    tree: &QuadTree,
    weights: &mut W,
    mut f: impl FnMut(Cell, f64),
) {
    let nodes = tree.nodes();
    let Some(first) = nodes.first() else { return };
    let refine_to = weights.refine_below_leaves_to();
    // (node, sums, cell, pdf so far)
    let mut stack: Vec<(Option<usize>, [f32; 4], Cell, f32)> =
        vec![(Some(0), first.sums, Cell::ROOT, 1.0)];
    while let Some((node, sums, cell, pdf)) = stack.pop() {
        let Some((w, total, _)) = resolve(weights, cell, sums) else {
            continue;
        };
        if node.is_none() && (nearly_uniform(w) || cell_mass(pdf, cell) < VIRTUAL_MIN_MASS) {
            f(cell, cell_mass(pdf, cell) as f64);
            continue;
        }
        for k in 0..4 {
            if w[k] == 0.0 {
                continue;
            }
            let child_pdf = step_pdf(pdf, w[k], total);
            let child = cell.child(k);
            match node.map_or(0, |i| nodes[i].children[k]) {
                0 if child.depth < refine_to => stack.push((None, [sums[k]; 4], child, child_pdf)),
                0 => f(child, cell_mass(child_pdf, child) as f64),
                c => stack.push((Some(c as usize), nodes[c as usize].sums, child, child_pdf)),
            }
        }
    }
}

// `sample`, `pdf` and `root_total` give weights that are the radiance
// under another type (product guiding's fallback at cosine lobes and deeper
// vertices) to the radiance descent's own code: the same weights and
// values, without the product's memo and refinement branches at every
// level. On cornell-box (no glossy lobe, so radiance weights at every
// vertex) the product ran 12 % slower than radiance guiding; this cut its
// CPU time by 0.94–0.95 ± 0.03 (48 spp, --no-plan, side by side, two sets
// of 4 and 7 rounds).

/// Samples a point of the square and its square-measure pdf.
#[inline]
pub fn sample<W: ChildWeights>(tree: &QuadTree, weights: &mut W, u: Vec2) -> Option<(Vec2, f32)> {
    let descended = if weights.is_radiance() {
        sample_descend(tree, &mut RadianceWeights, u)
    } else {
        sample_descend(tree, weights, u)
    };
    descended.map(|d| (d.point, d.pdf_square))
}

/// Square-measure pdf of the point `p`.
#[inline]
pub fn pdf<W: ChildWeights>(tree: &QuadTree, weights: &mut W, p: Vec2) -> f32 {
    if weights.is_radiance() {
        pdf_descend(tree, &mut RadianceWeights, p).0
    } else {
        pdf_descend(tree, weights, p).0
    }
}

/// Samples a world direction; returns it with its solid-angle pdf.
#[inline]
pub fn sample_direction<W: ChildWeights>(
    tree: &QuadTree,
    weights: &mut W,
    u: Vec2,
) -> Option<(Vec3, f32)> {
    sample(tree, weights, u).map(|(p, pdf)| (square_to_dir(p), pdf * SQUARE_TO_SOLID_ANGLE_PDF))
}

/// Solid-angle pdf of a unit world direction.
#[inline]
pub fn pdf_direction<W: ChildWeights>(tree: &QuadTree, weights: &mut W, d: Vec3) -> f32 {
    pdf(tree, weights, dir_to_square(d)) * SQUARE_TO_SOLID_ANGLE_PDF
}

/// Σ_k w_k at the root alone (one weight call), for callers that need the
/// adjoint estimate without sampling. 0 when the weights vanish (nothing
/// to guide towards); NaN or ∞ when a weight or their total is not finite,
/// which the descent would silently replace, so that the caller can count
/// it.
pub fn root_total<W: ChildWeights>(tree: &QuadTree, weights: &mut W) -> f32 {
    let sums = tree.nodes()[0].sums;
    let w = if weights.is_radiance() {
        RadianceWeights.child_weights(Cell::ROOT, sums)
    } else {
        weights.child_weights(Cell::ROOT, sums)
    };
    clamped_total(w).1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::guiding::quadtree::QuadNode;

    #[test]
    fn empty_tree_has_no_distribution_and_uniform_is_uniform() {
        let t = QuadTree::new();
        assert!(sample(&t, &mut RadianceWeights, Vec2::splat(0.5)).is_none());
        assert_eq!(pdf(&t, &mut RadianceWeights, Vec2::splat(0.5)), 0.0);
        let t = QuadTree::uniform(2.0);
        let (p, d) = sample(&t, &mut RadianceWeights, Vec2::new(0.3, 0.7)).unwrap();
        assert_eq!(d, 1.0);
        // one level: the sample is rescaled, not redrawn
        assert!((p - Vec2::new(0.3, 0.7)).length() < 1e-6, "{p:?}");
        assert_eq!(root_total(&t, &mut RadianceWeights), 8.0);
    }

    #[test]
    fn split_never_picks_a_zero_side_and_rescales_into_unit_interval() {
        for u in [0.0f32, 0.3, 0.5, ONE_MINUS_EPS] {
            assert_eq!(split(u, 0.0, 2.0).0, 1);
            assert_eq!(split(u, 2.0, 0.0).0, 0);
            assert_eq!(split(u, 1e-30, 1.0).0, (u > 0.0) as usize);
            let (_, r) = split(u, 1.0, 3.0);
            assert!((0.0..=1.0).contains(&r), "{u} → {r}");
        }
        // A subnormal side chosen by u = 0: the remainder may be 0·∞, and
        // the sampler must still return a finite point with a matching pdf.
        let t = QuadTree::from_nodes(vec![QuadNode {
            sums: [1e-40, 1.0, 0.0, 1.0],
            children: [0; 4],
        }])
        .unwrap();
        let (p, d) = sample(&t, &mut RadianceWeights, Vec2::ZERO).unwrap();
        assert!(p.is_finite() && p.x < 0.5 && p.y < 0.5, "{p:?}");
        assert!(d > 0.0 && d == pdf(&t, &mut RadianceWeights, p));
        assert_eq!(split(ONE_MINUS_EPS, 1.999_999_9, 0.0).0, 0);
        assert_eq!(split(0.2, 1.0, 3.0), (0, 0.8));
        assert_eq!(split(0.625, 1.0, 3.0), (1, 0.5));
        // The row split follows the chosen column's weights.
        let w = [1.0, 1.0, 3.0, 0.0];
        assert_eq!(choose_child(Vec2::new(0.2, 0.5), w).0, 2);
        assert_eq!(choose_child(Vec2::new(0.9, 0.5), w).0, 1);
    }

    #[test]
    fn fallbacks_are_deterministic() {
        // root → child 0 has a node whose sums are all zero: uniform below.
        let root = QuadNode {
            sums: [1.0, 0.0, 0.0, 1.0],
            children: [1, 0, 0, 0],
        };
        let t = QuadTree::from_nodes(vec![root, QuadNode::default()]).unwrap();
        let p = Vec2::new(0.1, 0.1);
        assert_eq!(pdf(&t, &mut RadianceWeights, p), 2.0);
        // Weights that are NaN everywhere fall back to radiance at every level.
        struct Nan;
        impl ChildWeights for Nan {
            fn child_weights(&mut self, _: Cell, _: [f32; 4]) -> [f32; 4] {
                [f32::NAN; 4]
            }
        }
        // Counted at each level below the root (the root's guard is the
        // caller's): here one, the tree's second level.
        let counted =
            || crate::guards::thread_count(crate::guards::GuardEvent::DescentWeightsNonfinite);
        let before = counted();
        assert_eq!(pdf(&t, &mut Nan, p), 2.0);
        assert_eq!(counted(), before + 1);
        assert_eq!(pdf_descend(&t, &mut Nan, p).1, 0.0);
        assert_eq!(counted(), before + 2);
        // An overflowing total of finite weights is not finite either.
        struct Huge;
        impl ChildWeights for Huge {
            fn child_weights(&mut self, cell: Cell, _: [f32; 4]) -> [f32; 4] {
                [if cell.depth == 0 { 1.0 } else { f32::MAX }; 4]
            }
        }
        assert_eq!(pdf(&t, &mut Huge, p), 1.0);
        assert_eq!(counted(), before + 3);
        assert_eq!(pdf(&t, &mut RadianceWeights, p), 2.0);
        assert_eq!(counted(), before + 3);
        // A zero child is never sampled and has pdf 0.
        assert_eq!(pdf(&t, &mut RadianceWeights, Vec2::new(0.7, 0.2)), 0.0);
        for i in 0..1000 {
            let u = Vec2::new(
                (i as f32 + 0.5) / 1000.0,
                ((i * 7919) % 1000) as f32 / 1000.0,
            );
            let (q, d) = sample(&t, &mut RadianceWeights, u).unwrap();
            assert!(d > 0.0 && d == pdf(&t, &mut RadianceWeights, q));
        }
    }
}
