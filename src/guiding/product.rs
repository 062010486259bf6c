//! Product guiding (Diolatzis et al. 2020): the child weight of the shared
//! descent is L_k·D_k, where L_k is the stored radiance of child k and D_k
//! the integral of the cosine-weighted BSDF over the child's spherical cell,
//! computed with linearly transformed cosines.
//!
//! The paper's fallbacks:
//! - outgoing elevation θ_o ≥ 85° → radiance-only weights (the LTC fit is
//!   poor there and the lobe is mostly clipped);
//! - GGX lobes with α > 0.5 → treated as diffuse (inside `ShadingLtc`);
//! - a product that vanishes over the whole sphere → BSDF sampling;
//! - all children's products vanishing under a non-zero parent (chord or
//!   clipping error) → radiance weights at that level (inside the descent).

use super::descent::ChildWeights;
use super::guide::{WeightModel, reflected_radiance_estimate};
pub use super::pixel_reuse::{LobeKey, LobeSlot, ProductCache};
use crate::directional::Cell;
use crate::integrator::guide::VertexContext;
use crate::ltc::{LtcOptions, LtcTable, ProductKernel, ShadingLtc};

#[derive(Clone, Copy)]
pub struct ProductModel<'t> {
    pub table: &'t LtcTable,
    pub kernel: ProductKernel,
    pub options: LtcOptions,
    /// Radiance-only weights everywhere: what a run falls back to when it
    /// measures that the product does not pay.
    pub radiance_only: bool,
    /// What vertices whose lobes are all cosines get.
    pub cosine_lobes: CosineLobes,
    /// The first this many vertices of a path take product weights, deeper
    /// ones radiance weights; 0: every vertex (the paper's setting). See
    /// [`DEFAULT_PRODUCT_VERTICES`].
    pub product_vertices: u32,
    /// A pixel's paths reuse the product lobe of their first vertex while
    /// they hit the same lobe (see [`ProductCache`]); off: every vertex
    /// computes its own (the paper's setting).
    pub reuse_in_pixel: bool,
    /// Share β of the guided samples at product-weighted vertices drawn
    /// from the radiance descent ([`super::defensive`]); 0: the paper's
    /// product alone.
    pub radiance_share: f32,
}

/// Product weights at the first vertex of each path only, by default.
///
/// Measured with NEE at 16 spp (1 thread each, two runs side by side,
/// 2 seeds, product weights forced with `--no-plan`; variance per sample of
/// the final iteration, CPU seconds), the product at every vertex against
/// the first vertex only against radiance guiding:
///
/// | scene | every vertex | first vertex | radiance |
/// |---|---|---|---|
/// | staircase | 0.1166, 37.9 s | 0.1190, 25.6 s | 0.1203, 20.0 s |
/// | living-room | 3.34, 35.5 s | 3.31, 28.7 s | 3.51, 27.4 s |
/// | veach-ajar | 41.6, 15.0 s | 41.7, 13.0 s | 43.0, 10.8 s |
///
/// The deeper vertices' product cost 13–32 % of the run and bought no
/// variance the runs could resolve: with NEE a deeper vertex's direct light
/// comes from the light sample, and its indirect contribution reaches the
/// pixel through the blur of the earlier bounces.
///
/// Without NEE (the results pages' setting) the deeper vertices must find
/// the lights themselves, and their product does pay per sample: at 64 spp
/// on staircase (2 seeds, `ltcguide attribute`) the expected relMSE at
/// equal samples falls from 0.94× radiance guiding's to 0.80× with product
/// weights at every vertex. But the run's time rises from 1.22× to 1.73×
/// radiance guiding's (no lobe reuse below the first vertex: every deeper
/// vertex builds its lobe and its coarse levels), so at equal time the
/// first vertex alone stays ahead, 1.14× against 1.38×
/// (docs/results-reading.md, session 67).
pub const DEFAULT_PRODUCT_VERTICES: u32 = 1;

/// Where product weights apply for a `product_vertices` setting, whether
/// first-vertex product lobes are reused across neighbouring paths, and
/// the guided samples' radiance share there, for plan lines and reports.
pub fn product_weights_scope(
    product_vertices: u32,
    pixel_reuse: bool,
    radiance_share: super::defensive::RadianceShare,
) -> String {
    let scope = match product_vertices {
        0 => "every vertex".into(),
        1 => "the first vertex of each path, radiance weights deeper".into(),
        n => format!("the first {n} vertices of each path, radiance weights deeper"),
    };
    let reuse = if pixel_reuse {
        "the first vertex's lobe reused across the paths of neighbouring pixels"
    } else {
        "no lobe reuse across paths"
    };
    let share = radiance_share.describe();
    format!("{scope}; {share}; {reuse}")
}

/// "product weights at …, cosine lobes: …": the product's whole scope, as
/// `compare`'s settings line and `attribute`'s header name it.
pub fn product_scope_phrase(
    product_vertices: u32,
    pixel_reuse: bool,
    radiance_share: super::defensive::RadianceShare,
    cosine_lobes: CosineLobes,
) -> String {
    format!(
        "product weights at {}, cosine lobes: {}",
        product_weights_scope(product_vertices, pixel_reuse, radiance_share),
        format!("{cosine_lobes:?}").to_lowercase()
    )
}

/// The child weights at a vertex whose lobes are all cosines (diffuse
/// surfaces, plastic without a glossy coat, GGX lobes rougher than
/// `rough_as_diffuse_above`).
///
/// The paper multiplies the radiance by the cosine there too. Measured with
/// NEE (1 thread each, two runs side by side, 2 seeds, product weights
/// forced with `--no-plan`): on cornell-box (only cosine lobes, 32 spp) the
/// cosine product lowers the variance per sample by 3 % and doubles the
/// CPU time (46.4 s against 22.9 s for radiance weights); on staircase
/// (16 spp) radiance weights at its cosine vertices cut the product's CPU
/// time by 14 % (41.5 → 35.8 s) at the same variance per sample (0.1176
/// and 0.1180). The cosine barely varies across the cells radiance
/// guiding already resolves, so it ranks their children by little, at the
/// cost of an integral per visited node. Without NEE (the results pages'
/// setting) the cosine product keeps a vertex's samples above its surface
/// and does pay per sample, but not at equal time: on staircase at 64 spp
/// with product weights at every vertex, the expected relMSE at equal
/// samples is 0.70× radiance guiding's with it and 0.80× without, at 1.92×
/// and 1.73× the run's time (equal time: 1.34× and 1.38×, against 1.14×
/// for the defaults; docs/results-reading.md, session 67).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum CosineLobes {
    /// Radiance weights: the cheaper strategy, measured more efficient.
    #[default]
    Radiance,
    /// The paper's cosine product, from the diffuse form factors.
    Product,
}

/// True when every lobe with weight is a cosine to the product (and some
/// lobe has weight): diffuse, or GGX that `options` integrates as a cosine.
fn only_cosine_lobes(lobes: &crate::bsdf::Lobes, options: &LtcOptions) -> bool {
    let ggx = lobes.ggx.iter().take(lobes.ggx_count);
    let mut weighted = ggx.filter(|g| g.weight > 0.0).peekable();
    let has_rough = weighted.peek().is_some();
    let glossy = weighted.any(|g| !options.integrates_as_cosine(g.alpha));
    !glossy && (lobes.diffuse > 0.0 || has_rough)
}

/// The LTC options product guiding runs with. The API's defaults are
/// accurate; a guider only needs D_k good enough to rank children, since an
/// approximate product costs variance, never bias (sample and pdf share the
/// approximation). So:
/// - straddling diffuse and glossy children below level 1 take the sphere
///   approximation instead of exact clipping, as in the paper's optimised
///   variant;
/// - glossy children from level 4 on are plain chord quads, where levels
///   4–5 would otherwise follow their parallels with 2–3× the edges (from
///   level 2 on, a lobe of α = 0.05 can lose 19 % of its mass to the wrong
///   level-2 child; from level 4 on, 2 %: the test below), and levels 2–3
///   follow their parallels with chords of the same 1/16 turn instead of
///   1/64 (level 2: 30 edges instead of 102; worst child error of the test
///   below, α = 0.05: 2.05 % → 2.35 % of the lobe);
/// - diffuse children from level 2 on (every level below the exact
///   quarter spheres), and glossy children once their mapped size is below
///   0.3 (instead of 0.088), take density × solid angle at their centre.
///
/// Measured at 16 spp with NEE (2 threads, per-sample variance of the final
/// iteration, product weights forced with `--no-plan`):
/// - exact clipping → sphere approximation: cornell-box 53.8 → 33.9 CPU s,
///   variance 0.0115 both ways; staircase 88.0 → 81.1 s, 0.1254 → 0.1227;
/// - the rest, on a loaded machine (CPU seconds, interleaved runs):
///   staircase −9 % for chord quads from level 2 (variance 0.01386 →
///   0.01351; not kept, see above) and −7 % for the centre switches
///   (0.01377 → 0.01320); cornell-box −8 % for the centre switches
///   (0.001281 → 0.001283);
/// - diffuse centres from level 2 instead of 3 (session 7; 1 thread per
///   run, two runs side by side, 2 seeds, 16/32 spp): cornell-box with
///   the cosine product forced 46.4 → 39.9 CPU s, variance per sample
///   0.01217 → 0.01222; staircase (radiance weights at cosine vertices)
///   35.8 → 34.4 s, 0.1180 → 0.1166: the level-2 form factors, clipped
///   by the sphere approximation's band wherever its cap crosses the
///   horizon, cost more than the centres and ranked no better.
pub fn guiding_ltc_options() -> LtcOptions {
    LtcOptions {
        exact_crossing_depth: 1,
        plain_quad_depth: 4,
        diffuse_centre_depth: 2,
        deep_cell_size: 0.3,
        ..LtcOptions::default()
    }
}

/// Slots of the child-integral memo (a power of two).
const MEMO_SLOTS: usize = 256;

/// Memo of the child integrals of one product lobe, direct-mapped by cell.
///
/// At one vertex, `root_total`, the sample descent and the pdf descents
/// all start at the root and share their top levels; with the lobe reused
/// across neighbouring paths (`guiding::pixel_reuse`), every descent of
/// those paths shares them too. A slot per depth (before) held one
/// descent's prefix, so each path of a pixel recomputed what the previous
/// one had evicted; 256 slots hold the union of a pixel's descents (1024,
/// for lobes reused across pixels, measured no faster: staircase with NEE,
/// 16 spp, 6 side-by-side runs, CPU ×1.01). A value is the
/// same pure function of the cell whether computed or recalled, so sample
/// and pdf stay bit-identical, and a collision only costs a recomputation.
#[derive(Clone, Debug)]
pub struct ChildMemo {
    /// Packed (depth, ix, iy) of the cell in each slot; `u64::MAX` when empty.
    keys: [u64; MEMO_SLOTS],
    values: [[f32; 4]; MEMO_SLOTS],
}

impl Default for ChildMemo {
    fn default() -> Self {
        ChildMemo {
            keys: [u64::MAX; MEMO_SLOTS],
            values: [[0.0; 4]; MEMO_SLOTS],
        }
    }
}

impl ChildMemo {
    /// D of `cell`'s children, from the memo or computed by `f`.
    #[inline]
    pub fn get_or(&mut self, cell: Cell, f: impl FnOnce() -> [f32; 4]) -> [f32; 4] {
        // depth < 32 and ix, iy < 2^depth: the fields cannot overlap.
        let key = ((cell.depth as u64) << 58) | ((cell.ix as u64) << 29) | cell.iy as u64;
        let slot = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 56) as usize % MEMO_SLOTS;
        if self.keys[slot] == key {
            return self.values[slot];
        }
        let v = f();
        self.keys[slot] = key;
        self.values[slot] = v;
        v
    }

    /// Forgets every cell (for a new lobe in the same storage).
    pub fn clear(&mut self) {
        self.keys.fill(u64::MAX);
    }
}

/// A shading point's product lobe: its LTC mixture, the kernel that
/// integrates it and the memo of the child integrals computed so far. It
/// lives in the worker's [`ProductCache`] and the vertex borrows it, so it
/// is never moved, and the next paths can reuse it.
pub struct ProductLobe {
    pub ltc: ShadingLtc,
    pub kernel: ProductKernel,
    pub memo: ChildMemo,
}

impl ProductLobe {
    pub fn new(ltc: ShadingLtc, kernel: ProductKernel) -> Self {
        ProductLobe {
            ltc,
            kernel,
            memo: ChildMemo::default(),
        }
    }
}

/// Per-vertex weights: the product, or the radiance fallback.
pub enum ProductWeights<'a> {
    Product(&'a mut ProductLobe),
    /// `albedo` is the LTC's estimate where a lobe was built (grazing ω_o);
    /// `None` where none was: the adjoint then takes the BSDF's estimate,
    /// computed only where roulette reads it (as radiance guiding does),
    /// not at every radiance-weighted vertex.
    ///
    /// A reference into the worker's lobe slot rather than the value, so
    /// that both variants hold one pointer and the weights travel in two
    /// registers. With an `Option<f32>` here the enum went through memory,
    /// and `SdGuide::vertex` reloaded it in a wider piece than it had been
    /// stored in: a store-forwarding stall at every vertex.
    RadianceOnly {
        albedo: Option<&'a f32>,
    },
}

impl ChildWeights for ProductWeights<'_> {
    #[inline]
    fn child_weights(&mut self, cell: Cell, radiance: [f32; 4]) -> [f32; 4] {
        match self {
            ProductWeights::Product(lobe) => {
                let ProductLobe { ltc, kernel, memo } = &mut **lobe;
                let d = memo.get_or(cell, || ltc.child_integrals(cell, *kernel));
                [
                    radiance[0] * d[0],
                    radiance[1] * d[1],
                    radiance[2] * d[2],
                    radiance[3] * d[3],
                ]
            }
            ProductWeights::RadianceOnly { .. } => radiance,
        }
    }

    fn is_radiance(&self) -> bool {
        matches!(self, ProductWeights::RadianceOnly { .. })
    }

    /// Only glossy lobes vary faster than the radiance tree resolves; a
    /// cosine lobe is smooth at every leaf size the tree produces.
    fn refine_below_leaves_to(&self) -> u32 {
        match self {
            ProductWeights::Product(lobe) if lobe.ltc.glossy_count > 0 => {
                crate::guiding::quadtree::MAX_DEPTH
            }
            _ => 0,
        }
    }
}

impl ProductModel<'_> {
    /// Builds the weights at a shading point into `slot`.
    fn build(&self, lobes: &crate::bsdf::Lobes, ctx: &VertexContext, slot: &mut LobeSlot) {
        // Two-sided mirroring flips z only (the lobes' frame).
        let w = ctx.wo_local;
        let wo = if lobes.side < 0.0 {
            glam::Vec3::new(w.x, w.y, -w.z)
        } else {
            w
        };
        let ltc = ShadingLtc::new(lobes, ctx.frame, wo, self.table, &self.options);
        if !(ltc.total() > 0.0) {
            slot.set_vanishes();
        } else if ltc.prefers_radiance_only() {
            slot.set_radiance_only(ltc.total());
        } else {
            slot.set_product(ltc, self.kernel);
        }
    }

    /// The weights at a vertex whose lobes must be looked at. Kept out of
    /// line: its frame holds a lobe, an LTC and a memo (13 KiB, probed page
    /// by page), which the radiance-weighted vertices, most of a path's,
    /// set up at every call while it was inlined in `weights`. On
    /// cornell-box, where every vertex takes radiance weights, the product's
    /// CPU over radiance guiding's went from 1.03 to 1.015 (the minimum of 9
    /// runs each; 1.08 before `weights` returned at diffuse BSDFs).
    #[inline(never)]
    fn lobe_weights<'a>(
        &'a self,
        ctx: &VertexContext,
        cache: &'a mut ProductCache,
    ) -> Option<ProductWeights<'a>> {
        let lobes = ctx.bsdf.lobes(ctx.wo_local);
        if self.cosine_lobes == CosineLobes::Radiance && only_cosine_lobes(&lobes, &self.options) {
            return Some(ProductWeights::RadianceOnly { albedo: None });
        }
        let build = |slot: &mut LobeSlot| self.build(&lobes, ctx, slot);
        if self.reuse_in_pixel && ctx.vertex_index == 0 {
            cache
                .first_vertex(LobeKey::new(lobes, ctx), ctx.revisit, build)
                .weights()
        } else {
            cache.other_vertex(build).weights()
        }
    }
}

impl WeightModel for ProductModel<'_> {
    type Weights<'a>
        = ProductWeights<'a>
    where
        Self: 'a;
    type Cache = ProductCache;

    #[inline]
    fn weights<'a>(
        &'a self,
        ctx: &VertexContext,
        cache: &'a mut ProductCache,
    ) -> Option<ProductWeights<'a>> {
        let radiance_weights = Some(ProductWeights::RadianceOnly { albedo: None });
        let deeper = self.product_vertices > 0 && ctx.vertex_index >= self.product_vertices;
        if self.radiance_only || deeper {
            return radiance_weights;
        }
        // A diffuse BSDF is cosine-only at every ω_o: radiance weights,
        // without building its lobes (most vertices of a diffuse scene). A
        // black texel or back face gets them too, as in radiance guiding.
        if self.cosine_lobes == CosineLobes::Radiance && ctx.bsdf.is_diffuse() {
            return radiance_weights;
        }
        self.lobe_weights(ctx, cache)
    }

    /// With product weights the root normaliser Σ_k L_k·D_k already
    /// estimates the reflected radiance; in the radiance fallback it is
    /// estimated as for radiance guiding.
    fn adjoint(
        &self,
        weights: &ProductWeights<'_>,
        ctx: &VertexContext,
        root_total: f32,
        root_radiance: [f32; 4],
    ) -> f32 {
        match weights {
            ProductWeights::Product(_) => root_total,
            ProductWeights::RadianceOnly { albedo } => {
                let albedo = albedo
                    .copied()
                    .unwrap_or_else(|| ctx.bsdf.albedo_estimate(ctx.wo_local));
                reflected_radiance_estimate(ctx.frame, ctx.wo_local, albedo, root_radiance)
            }
        }
    }

    fn radiance_share(&self) -> f32 {
        self.radiance_share
    }

    fn name(&self) -> &'static str {
        if self.radiance_only {
            "radiance"
        } else {
            "product"
        }
    }

    fn cheaper(&self) -> Option<Self> {
        (!self.radiance_only).then_some(ProductModel {
            radiance_only: true,
            ..*self
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{GgxLobe, Lobes};
    use crate::guiding::descent;
    use crate::guiding::quadtree::{QuadNode, QuadTree};
    use crate::math::Frame;
    use crate::sampling::{Distribution1D, Rng};
    use glam::Vec3;

    fn product_lobe(table: &LtcTable, alpha: f32) -> ProductLobe {
        let frame = Frame::from_normal(Vec3::new(0.3, -0.5, 0.8).normalize());
        let wo = Vec3::new(0.55, 0.45, 0.707).normalize();
        let lobes = Lobes {
            diffuse: 0.4,
            ggx: [GgxLobe { weight: 0.6, alpha }],
            ggx_count: 1,
            delta: 0.0,
            side: 1.0,
        };
        let ltc = ShadingLtc::new(&lobes, &frame, wo, table, &LtcOptions::default());
        ProductLobe::new(ltc, ProductKernel::Simd)
    }

    /// The guider's options trade accuracy for speed, but stay close to the
    /// exact integrals against the lobe: at random normals, outgoing
    /// directions and descents to depth 8, for a diffuse lobe and for a
    /// rough-plastic mixture with α = 0.05 and 0.3, every child is finite,
    /// non-negative and within 4.5 % of the lobe's whole integral of the
    /// API's accurate value (measured worst: printed), and the options do
    /// change something. The worst is the cosine lobe's level-2 centre rule
    /// (3.7 %; below 3 % with form factors there), which the variance per sample
    /// did not notice (see `guiding_ltc_options`).
    #[test]
    fn guiding_options_stay_close_to_the_exact_children() {
        let table = LtcTable::load_default().unwrap();
        let mut rng = Rng::new(3, 9);
        let mixtures = [(1.0, 0.0, 0.1), (0.5, 0.5, 0.05), (0.3, 0.7, 0.3)];
        for (diffuse, glossy, alpha) in mixtures {
            let lobes = Lobes {
                diffuse,
                ggx: [GgxLobe {
                    weight: glossy,
                    alpha,
                }],
                ggx_count: (glossy > 0.0) as usize,
                delta: 0.0,
                side: 1.0,
            };
            let mut worst = 0.0f32;
            for _ in 0..40 {
                let n = crate::sampling::square_to_uniform_sphere(rng.next_2d());
                let frame = Frame::from_normal(n);
                let mut wo = crate::sampling::square_to_uniform_sphere(rng.next_2d());
                wo.z = wo.z.abs().max(0.1);
                let wo = wo.normalize();
                let exact = ShadingLtc::new(&lobes, &frame, wo, &table, &LtcOptions::default());
                let fast = ShadingLtc::new(&lobes, &frame, wo, &table, &guiding_ltc_options());
                // Descend towards the lobe's larger children, as sampling does.
                let mut cell = Cell::ROOT;
                for _ in 0..8 {
                    let a = exact.child_integrals(cell, ProductKernel::Simd);
                    let b = fast.child_integrals(cell, ProductKernel::Simd);
                    for k in 0..4 {
                        assert!(b[k].is_finite() && b[k] >= 0.0, "{b:?}");
                        worst = worst.max((a[k] - b[k]).abs() / exact.total());
                    }
                    let (k, _, _) = Distribution1D::new(&a).sample_discrete(rng.next_f32());
                    cell = cell.child(k);
                }
            }
            eprintln!(
                "diffuse {diffuse} glossy {glossy} α {alpha}: worst child error {worst:.4} of the lobe"
            );
            assert!(worst < 0.045, "{worst}");
            assert!(worst > 0.0, "the guiding options changed nothing");
        }
    }

    /// A slot rebuilt in place forgets the previous lobe's child integrals:
    /// after a lobe of α = 0.05 was descended, a lobe of α = 0.3 built into
    /// the same slot gives the weights of a fresh one, bit for bit.
    #[test]
    fn a_slot_rebuilt_in_place_forgets_the_previous_lobe() {
        let table = LtcTable::load_default().unwrap();
        let mut rng = Rng::new(4, 4);
        let t = tree(&mut rng);
        let mut slot = LobeSlot::default();
        let set = |slot: &mut LobeSlot, alpha| {
            let lobe = product_lobe(&table, alpha);
            slot.set_product(lobe.ltc, lobe.kernel);
        };
        set(&mut slot, 0.05);
        let sharp = descent::root_total(&t, &mut slot.weights().unwrap());
        slot.set_radiance_only(1.0);
        assert!(matches!(
            slot.weights(),
            Some(ProductWeights::RadianceOnly { .. })
        ));
        set(&mut slot, 0.3);
        let mut fresh = product_lobe(&table, 0.3);
        let rough = descent::root_total(&t, &mut ProductWeights::Product(&mut fresh));
        assert_ne!(sharp.to_bits(), rough.to_bits());
        let mut w = slot.weights().unwrap();
        assert_eq!(descent::root_total(&t, &mut w).to_bits(), rough.to_bits());
        for _ in 0..50 {
            let q = rng.next_2d();
            let a = descent::pdf(&t, &mut w, q);
            let b = descent::pdf(&t, &mut ProductWeights::Product(&mut fresh), q);
            assert_eq!(a.to_bits(), b.to_bits());
        }
        slot.set_vanishes();
        assert!(slot.weights().is_none());
    }

    /// A full tree to node depth 3 with random sums (some zero), and a chain
    /// below its first depth-3 node down to the deepest cells allowed.
    fn tree(rng: &mut Rng) -> QuadTree {
        const INTERNAL: u32 = 1 + 4 + 16;
        const FULL: u32 = INTERNAL + 64;
        const CHAIN: u32 = 16;
        let nodes = (0..FULL + CHAIN)
            .map(|i| {
                let sums = std::array::from_fn(|_| {
                    let x = rng.next_f32();
                    if x < 0.1 { 0.0 } else { x }
                });
                let mut children = [0u32; 4];
                if i < INTERNAL {
                    children = std::array::from_fn(|k| 4 * i + 1 + k as u32);
                } else if i == INTERNAL {
                    children[1] = FULL;
                } else if i >= FULL && i + 1 < FULL + CHAIN {
                    children[1] = i + 1;
                }
                QuadNode { sums, children }
            })
            .collect();
        QuadTree::from_nodes(nodes).unwrap()
    }

    /// Samples and pdfs with one memoised weight object, interleaved at
    /// random points, against fresh (empty-memo) weights: every pdf is bit
    /// for bit the same, and so are the weights at every visited node.
    #[test]
    fn memo_keeps_sample_and_pdf_bit_identical() {
        let table = LtcTable::load_default().unwrap();
        let mut rng = Rng::new(7, 2);
        let t = tree(&mut rng);
        for alpha in [0.05f32, 0.3] {
            let mut lobe = product_lobe(&table, alpha);
            let mut w = ProductWeights::Product(&mut lobe);
            let fresh = || product_lobe(&table, alpha);
            let root = descent::root_total(&t, &mut w);
            assert_eq!(
                root.to_bits(),
                descent::root_total(&t, &mut ProductWeights::Product(&mut fresh())).to_bits()
            );
            let mut sampled = 0;
            for _ in 0..400 {
                let u = rng.next_2d();
                if let Some((p, pdf_s)) = descent::sample(&t, &mut w, u) {
                    sampled += 1;
                    let pdf_memo = descent::pdf(&t, &mut w, p);
                    let pdf_fresh = descent::pdf(&t, &mut ProductWeights::Product(&mut fresh()), p);
                    assert_eq!(pdf_s.to_bits(), pdf_memo.to_bits(), "{p:?}");
                    assert_eq!(pdf_s.to_bits(), pdf_fresh.to_bits(), "{p:?}");
                }
                // A pdf at an unrelated point in between evicts deep slots.
                let q = rng.next_2d();
                let a = descent::pdf(&t, &mut w, q);
                let b = descent::pdf(&t, &mut ProductWeights::Product(&mut fresh()), q);
                assert_eq!(a.to_bits(), b.to_bits());
            }
            assert!(sampled > 300);
        }
        // The memo itself: a hit returns what was stored, a miss recomputes.
        let mut m = ChildMemo::default();
        let c = Cell::ROOT.child(2).child(1);
        assert_eq!(m.get_or(c, || [1.0, 2.0, 3.0, 4.0]), [1.0, 2.0, 3.0, 4.0]);
        assert_eq!(m.get_or(c, || [9.0; 4]), [1.0, 2.0, 3.0, 4.0]);
        let d = Cell::ROOT.child(2).child(3);
        assert_eq!(m.get_or(d, || [5.0; 4]), [5.0; 4]);
        assert_eq!(m.get_or(c, || [6.0; 4]), [1.0, 2.0, 3.0, 4.0]);
        m.clear();
        assert_eq!(m.get_or(c, || [6.0; 4]), [6.0; 4]);
        // More cells than slots: each still gets its own value back.
        let mut cell = Cell::ROOT;
        for depth in 0..20 {
            for k in 0..4 {
                let child = cell.child(k);
                let v = [depth as f32, k as f32, 0.0, 1.0];
                assert_eq!(m.get_or(child, || v), v);
                assert_eq!(m.get_or(child, || [9.0; 4]), v);
            }
            cell = cell.child(depth % 4);
        }
    }
}
