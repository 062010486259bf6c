//! Reuse of the first vertex's product lobe across the paths of a pixel
//! and of its neighbours.
//!
//! A pixel's camera rays differ by less than a pixel, so their first hits
//! usually see the same material with the same normal, from outgoing
//! directions a fraction of a milliradian apart; the next pixel's, about
//! a milliradian further (staircase: 1.2 mrad per pixel). Their product
//! lobes (the LTC mixture and its child integrals D_k) are then the same
//! to well within the LTC fit's own error, yet each path paid for its own:
//! the mixture, and one node integral per quadtree depth of every descent.
//!
//! So the worker keeps the first vertex's lobe, with the memo of the child
//! integrals it has computed, and a later path whose first vertex has the
//! same lobe (the tolerances below, against the kept lobe's own key, so
//! reuse never drifts from it) samples and evaluates its pdfs with the
//! kept one. That is still unbiased: the vertex's sample and pdfs come
//! from one distribution, whichever lobe it was built from, and BSDF
//! sampling in the mixture keeps every direction the BSDF reflects to
//! reachable. The radiance L_k is never reused: it comes from the vertex's
//! own spatial leaf.
//!
//! The cache lives for one row block of the render loop (its pixels in
//! order, each pixel's paths one after the other) and is cleared at its
//! end (see `VertexCache`), so a path's distribution depends only on the
//! earlier paths of its own block, in their fixed order, and images stay
//! reproducible for any thread count. Clearing it at every pixel instead
//! (before session 14) built up to 2.8× the lobes: see [`ProductCache`].

use super::product::{ProductLobe, ProductWeights};
use crate::bsdf::Lobes;
use crate::integrator::guide::{VertexCache, VertexContext};
use crate::integrator::stats::RenderCounters;
use crate::ltc::{ProductKernel, ShadingLtc};
use glam::Vec3;

/// Two lobes' outgoing directions and normals may differ by this fraction
/// of their sharpest GGX α (in radians, as chord lengths)...
const DIRECTION_TOLERANCE_PER_ALPHA: f32 = 0.1;
/// ...and by at most this much (cosine lobes).
const MAX_DIRECTION_TOLERANCE: f32 = 0.01;
/// Relative difference allowed in the lobes' weights and α. A textured
/// reflectance changes the diffuse/glossy mix from texel to texel within a
/// pixel: on staircase (16 spp) 2 % let 23 % of the first vertices reuse
/// the lobe, 30 % let 64 % (of at most 75 % at that sample count), at the
/// same variance per sample (0.1170 and 0.1175; 0.1178 without reuse).
/// Only the mix is off, never a lobe's shape.
const WEIGHT_TOLERANCE: f32 = 0.3;

/// What the product lobe at a shading point depends on: the lobes and,
/// since they are isotropic, the world normal and outgoing direction.
#[derive(Clone, Copy, Debug)]
pub struct LobeKey {
    lobes: Lobes,
    normal: Vec3,
    wo: Vec3,
}

impl LobeKey {
    pub fn new(lobes: Lobes, ctx: &VertexContext) -> Self {
        LobeKey {
            lobes,
            normal: ctx.frame.n,
            wo: ctx.frame.to_world(ctx.wo_local),
        }
    }

    /// True when `other`'s lobe is this one's within the tolerances: the
    /// same lobe structure and side, weights and α within 30 %, normals
    /// and outgoing directions within a tenth of the sharpest α.
    pub fn matches(&self, other: &LobeKey) -> bool {
        let (a, b) = (&self.lobes, &other.lobes);
        let close = |x: f32, y: f32| (x - y).abs() <= WEIGHT_TOLERANCE * x.abs().max(y.abs());
        if a.side != b.side || a.ggx_count != b.ggx_count || !close(a.diffuse, b.diffuse) {
            return false;
        }
        let mut tolerance = MAX_DIRECTION_TOLERANCE;
        for (ga, gb) in a.ggx.iter().zip(&b.ggx).take(a.ggx_count) {
            if !close(ga.weight, gb.weight) || !close(ga.alpha, gb.alpha) {
                return false;
            }
            if ga.weight > 0.0 {
                tolerance = tolerance.min(DIRECTION_TOLERANCE_PER_ALPHA * ga.alpha.min(gb.alpha));
            }
        }
        let t2 = tolerance * tolerance;
        // NaN compares false: a non-finite key never matches.
        (self.normal - other.normal).length_squared() <= t2
            && (self.wo - other.wo).length_squared() <= t2
    }
}

/// What the product model built at a shading point, in storage that keeps
/// its lobe in place from one build to the next: the child memo is 6 KB,
/// and a build only clears its keys instead of initialising and moving it.
#[derive(Default)]
pub struct LobeSlot {
    built: Built,
    /// The last product lobe built here (kept while `built` says otherwise,
    /// for its storage).
    lobe: Option<ProductLobe>,
}

#[derive(Clone, Copy, Default)]
enum Built {
    /// The product vanishes everywhere: sample the BSDF.
    #[default]
    Vanishes,
    RadianceOnly {
        albedo: f32,
    },
    Product,
}

impl LobeSlot {
    pub fn set_vanishes(&mut self) {
        self.built = Built::Vanishes;
    }

    pub fn set_radiance_only(&mut self, albedo: f32) {
        self.built = Built::RadianceOnly { albedo };
    }

    pub fn set_product(&mut self, ltc: ShadingLtc, kernel: ProductKernel) {
        match &mut self.lobe {
            Some(lobe) => {
                lobe.ltc = ltc;
                lobe.kernel = kernel;
                lobe.memo.clear();
            }
            None => self.lobe = Some(ProductLobe::new(ltc, kernel)),
        }
        self.built = Built::Product;
    }

    /// The weights built here; `None`: sample the BSDF.
    pub fn weights(&mut self) -> Option<ProductWeights<'_>> {
        match &self.built {
            Built::Vanishes => None,
            Built::RadianceOnly { albedo } => Some(ProductWeights::RadianceOnly {
                albedo: Some(albedo),
            }),
            Built::Product => Some(ProductWeights::Product(
                self.lobe.as_mut().expect("set_product stores a lobe"),
            )),
        }
    }
}

/// The worker's product lobes: the first vertex's, kept for the block's
/// next paths, and a slot for the other vertices (rebuilt at each, but
/// borrowed in place rather than moved with the weights).
///
/// Kept per row block rather than per pixel (session 14; 16 spp, NEE,
/// product weights forced with `--no-plan`, 1 thread per run, two runs
/// side by side, 2 seeds): lobes built 851 k → 434 k on staircase, 210 k →
/// 75 k on veach-ajar, 734 k → 490 k on living-room, for CPU ×0.98, ×1.00
/// and ×0.99 and variance per sample ×0.98, ×1.03 and ×1.00 (within the
/// seeds' spread). With the per-scene plan, product's spp/s relative to
/// radiance guiding on staircase went from 0.855 to 0.870 (8 runs each).
#[derive(Default)]
pub struct ProductCache {
    /// The key of `first`'s lobe; `None` when the block has none yet.
    first_key: Option<LobeKey>,
    first: LobeSlot,
    other: LobeSlot,
    /// First vertices that reused the kept lobe / built their own, since
    /// the last `end_block`.
    reused: u64,
    built: u64,
}

impl ProductCache {
    /// The first vertex's weights for `key`: the kept ones when their key
    /// matches, else what `build` puts in their place. A `revisit` (the
    /// vertex built again for a deferred pdf) is not counted as a reuse.
    pub fn first_vertex(
        &mut self,
        key: LobeKey,
        revisit: bool,
        build: impl FnOnce(&mut LobeSlot),
    ) -> &mut LobeSlot {
        if self.first_key.is_some_and(|kept| kept.matches(&key)) {
            self.reused += !revisit as u64;
        } else {
            self.built += 1;
            build(&mut self.first);
            self.first_key = Some(key);
        }
        &mut self.first
    }

    /// Any other vertex's weights: built anew at each.
    pub fn other_vertex(&mut self, build: impl FnOnce(&mut LobeSlot)) -> &mut LobeSlot {
        build(&mut self.other);
        &mut self.other
    }
}

impl VertexCache for ProductCache {
    fn end_block(&mut self, counters: &mut RenderCounters) {
        self.first_key = None;
        counters.product_lobes_reused += std::mem::take(&mut self.reused);
        counters.product_lobes_built += std::mem::take(&mut self.built);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::GgxLobe;

    fn key(diffuse: f32, alpha: f32, normal: Vec3, wo: Vec3) -> LobeKey {
        LobeKey {
            lobes: Lobes {
                diffuse,
                ggx: [GgxLobe { weight: 0.5, alpha }],
                ggx_count: 1,
                delta: 0.0,
                side: 1.0,
            },
            normal,
            wo,
        }
    }

    /// Within the tolerances a key matches; just beyond any of them, or
    /// with a NaN, it does not.
    #[test]
    fn keys_match_within_the_tolerances_only() {
        let n = Vec3::Z;
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let base = key(0.4, 0.1, n, wo);
        // α = 0.1: directions within 0.01.
        let tilt = |v: Vec3, d: f32| (v + Vec3::Y * d).normalize();
        assert!(base.matches(&key(0.4, 0.1, n, wo)));
        assert!(base.matches(&key(0.5, 0.1, tilt(n, 0.009), tilt(wo, 0.009))));
        assert!(!base.matches(&key(0.4, 0.1, tilt(n, 0.011), wo)));
        assert!(!base.matches(&key(0.4, 0.1, n, tilt(wo, 0.011))));
        assert!(!base.matches(&key(0.6, 0.1, n, wo)), "diffuse a third off");
        assert!(!base.matches(&key(0.4, 0.15, n, wo)), "α a third off");
        assert!(!base.matches(&key(f32::NAN, 0.1, n, wo)));
        assert!(!base.matches(&key(0.4, 0.1, Vec3::NAN, wo)));
        // A sharper lobe tightens the directions: α = 0.01 → 0.001.
        let sharp = key(0.4, 0.01, n, wo);
        assert!(sharp.matches(&key(0.4, 0.01, tilt(n, 0.0009), wo)));
        assert!(!sharp.matches(&key(0.4, 0.01, tilt(n, 0.0011), wo)));
    }

    /// The kept lobe is reused while keys match and rebuilt when not;
    /// `end_block` forgets it and hands over the counts.
    #[test]
    fn the_cache_reuses_rebuilds_and_forgets_per_block() {
        let mut cache = ProductCache::default();
        let mut builds = 0;
        let a = key(0.4, 0.1, Vec3::Z, Vec3::new(0.6, 0.0, 0.8));
        let b = key(0.4, 0.1, Vec3::X, Vec3::new(0.6, 0.0, 0.8));
        let mut get_or_revisit = |cache: &mut ProductCache, k: LobeKey, revisit: bool| {
            let slot = cache.first_vertex(k, revisit, |slot| {
                builds += 1;
                slot.set_radiance_only(builds as f32);
            });
            match slot.weights() {
                Some(ProductWeights::RadianceOnly { albedo: Some(a) }) => *a,
                _ => unreachable!(),
            }
        };
        assert_eq!(get_or_revisit(&mut cache, a, false), 1.0);
        assert_eq!(
            get_or_revisit(&mut cache, a, true),
            1.0,
            "a revisit is no reuse"
        );
        assert_eq!(get_or_revisit(&mut cache, a, false), 1.0);
        assert_eq!(get_or_revisit(&mut cache, b, false), 2.0);
        assert_eq!(get_or_revisit(&mut cache, a, false), 3.0);
        let mut counters = RenderCounters::default();
        cache.end_block(&mut counters);
        assert_eq!(
            get_or_revisit(&mut cache, a, false),
            4.0,
            "a new block builds its own"
        );
        assert_eq!(
            (counters.product_lobes_reused, counters.product_lobes_built),
            (1, 3)
        );
    }
}
