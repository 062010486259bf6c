//! The product guider's view of one shading point: the BSDF's lobes as a
//! mixture of LTCs, and the integral of that mixture over the 4 children of
//! any quadtree node.
//!
//! Per shading point ([`ShadingLtc::new`], ~0.3 µs measured on the shared
//! 2-core machine): one table lookup per glossy lobe and one 3×3 matrix
//! A = M⁻¹·R_φᵀ·S·Tᵀ that takes a *world* direction straight into the lobe's
//! cosine space (Tᵀ: world → shading frame; S: the two-sided mirror,
//! z ↦ side·z; R_φ: azimuth of ω_o; M⁻¹: the LTC), its determinant and its
//! switch depth. A diffuse lobe (and a GGX lobe rougher than
//! `rough_as_diffuse_above`, as in the paper) is a cosine around the
//! mirrored world normal. Nothing else depends on the shading point.
//!
//! Per node ([`ShadingLtc::child_integrals`]): D_k = Σ_lobes w·∫_{child k} D.
//! - level 1 (quarter spheres): exact clipping of the exact 5-vertex
//!   polygons (the equator split at its midpoint);
//! - diffuse lobes: F·n from the cell form factors (tabulated to level 5,
//!   then an f32 closed form), sphere-clipped across the horizon; to level 5
//!   a straddling cell is clipped exactly instead;
//! - glossy lobes: the chord polygons (parallels subdivided to level 5) are
//!   pushed through A and integrated by the f32 edge sum (scalar, or 16
//!   lanes: 4 children × 4 edges). The transformed vertices say exactly
//!   whether a child is above, below or across the horizon; only children
//!   across it need clipping — exact to level 5, the sphere approximation
//!   deeper;
//! - once a child, magnified by the lobe's map, is smaller than
//!   `deep_cell_size` (so f32 edge sums would lose to cancellation), it gets
//!   D(ω_centre)·Ω instead; sharp lobes switch deeper than broad ones;
//! - [`ProductKernel::Naive`] runs the f64 reference with exact clipping.
//!
//! Every returned value is finite and non-negative; anything else is zeroed
//! and counted ([`GuardEvent::LtcNonfinite`]).

mod diffuse;

use super::children_x16;
use super::coarse::coarse_children_scalar;
use super::fast_math::{cell_solid_angle, dyadic_sincos, step_sincos};
use super::level1::level1_children;
use super::polygon::{
    MAX_CACHED_POLYGON, cell_integral_reference, clipped_edge_sum_z, transform_rows,
    transformed_cached_polygon,
};
use super::quad::quad_children_scalar;
use super::sphere_clip::clipped_integral;
use super::table::LtcTable;
use crate::bsdf::Lobes;
use crate::directional::Cell;
use crate::guards::{GuardEvent, record};
use crate::math::Frame;
use glam::{DMat3, DVec3, Vec3};
use std::f32::consts::PI;

pub use super::options::{
    DEFAULT_DEEP_CELL_SIZE, EXACT_CLIP_DEPTH, EXACT_CROSSING_DEPTH, FIRST_PLAIN_QUAD_DEPTH,
    LtcOptions, ProductKernel,
};

/// Where a transformed child polygon lies with respect to the horizon. The
/// chords are great arcs, so the vertex signs decide it exactly.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HorizonSide {
    Above,
    Below,
    Crossing,
}

impl HorizonSide {
    #[inline]
    pub fn of_masks(above: u32, below: u32, all: u32) -> Self {
        if above & all == all {
            HorizonSide::Above
        } else if below & all == all {
            HorizonSide::Below
        } else {
            HorizonSide::Crossing
        }
    }
    pub fn of_vertices(verts: &[Vec3]) -> Self {
        if verts.iter().all(|v| v.z >= 0.0) {
            HorizonSide::Above
        } else if verts.iter().all(|v| v.z <= 0.0) {
            HorizonSide::Below
        } else {
            HorizonSide::Crossing
        }
    }
}

/// [`guard`] on the 4 children at once: one mask test instead of four
/// branches on the guider's per-level path.
#[inline(always)]
fn guard4(v: [f32; 4]) -> [f32; 4] {
    use wide::f32x4;
    let x = f32x4::from(v);
    let finite = x.is_finite();
    let bad = !finite.to_bitmask() & 0xF;
    if bad != 0 {
        record(GuardEvent::LtcNonfinite, bad.count_ones() as u64);
    }
    finite
        .bitselect(x.fast_max(f32x4::splat(0.0)), f32x4::splat(0.0))
        .to_array()
}

/// An LTC value or input weight made usable: negatives clamped to 0, and
/// NaN/Inf zeroed and counted.
#[inline]
fn guard(v: f32) -> f32 {
    if v.is_finite() {
        v.max(0.0)
    } else {
        record(GuardEvent::LtcNonfinite, 1);
        0.0
    }
}

/// Below this share of a glossy lobe, a plain-quad node's children come
/// from density × solid angle ([`GlossyLtc::edge_sums_unresolved`]): edge
/// sums err by ~2e-9 of the lobe, 2 % of a node of this mass.
pub const EDGE_SUM_MIN_MASS: f32 = 1e-7;

/// One glossy lobe, ready for cells: world → cosine-space map and weight.
#[derive(Clone, Copy, Debug)]
pub struct GlossyLtc {
    /// Lobe weight × GGX albedo: the lobe's share of ∫ f·cos.
    pub weight: f32,
    /// A = M⁻¹·R_φᵀ·S·Tᵀ by rows, f32.
    pub rows: [[f32; 3]; 3],
    /// A in f64 for the reference kernel.
    pub a64: DMat3,
    /// A turned about the cosine-space z axis for the plain-quad kernels
    /// ([`super::quad::quad_rows`]).
    pub quad_rows: [[f32; 3]; 3],
    /// sign(det A): a mirror flips the winding of the transformed cells.
    pub orientation: f32,
    /// |det A|, the Jacobian factor of the density.
    pub det_abs: f32,
    /// [`super::fast_math::THETA_OVER_SIN_SHORT`] × orientation/2π: the
    /// short-edge polynomial of the scalar plain-quad kernel with the
    /// integral's scale folded in, which the wide kernel would otherwise
    /// spend a multiplication on per node.
    pub short_poly: [f32; 4],
    /// `short_poly[k]` ÷ 4^(k+1), exactly (powers of 2): the same
    /// polynomial for the wide kernel, whose vertices have length 2, so that
    /// its cosines are 4·d and its cross products 4× the scalar's.
    pub short_poly_by_4: [f32; 4],
    /// Children at this depth or deeper use density × solid angle: the
    /// first depth where a cell (2π/2^d wide), magnified by ‖A‖_F, is
    /// smaller than the deep cell size.
    pub deep_depth: u32,
    /// Children at this level or deeper are plain chord quads (≥ 2).
    pub plain_quad_depth: u32,
    /// Children of nodes shallower than this that straddle the horizon are
    /// clipped exactly, deeper ones sphere-approximated.
    pub exact_crossing_depth: u32,
    /// Row 2 of cof(A) = A₀ × A₁ (rows): (A·c)×(A·c') = cof(A)·(c×c'), whose
    /// z component the Stokes quadrature of parallels integrates.
    pub cofactor_z: [f32; 3],
    /// Stokes nodes per segment for children at depths 2..=5 (0: chords).
    pub stokes_nodes: [u8; 4],
}

impl GlossyLtc {
    /// From a world→cosine map (f64), a weight, and the options that set
    /// its switch depths.
    pub fn from_map(a: DMat3, weight: f32, opts: &LtcOptions) -> Self {
        let deep_cell_size = opts.deep_cell_size;
        let det = a.determinant();
        let kappa = crate::math::frobenius_norm(&a);
        let deep_depth = super::fast_math::ceil_log2(
            2.0 * std::f64::consts::PI * kappa / deep_cell_size.max(1e-30) as f64,
        )
        .clamp(1, 64) as u32;
        let r = a.transpose();
        let row = |i: usize| crate::math::narrow_dvec3(r.col(i));
        let orientation = if det < 0.0 { -1.0 } else { 1.0 };
        GlossyLtc {
            weight,
            rows: [row(0), row(1), row(2)],
            a64: a,
            quad_rows: super::quad::quad_rows(&a),
            orientation,
            det_abs: det.abs() as f32,
            short_poly: super::quad::short_poly(orientation),
            short_poly_by_4: super::quad::short_poly_by_4(orientation),
            deep_depth,
            plain_quad_depth: opts
                .plain_quad_depth
                .clamp(EXACT_CLIP_DEPTH + 1, FIRST_PLAIN_QUAD_DEPTH),
            exact_crossing_depth: opts.exact_crossing_depth,
            cofactor_z: crate::math::narrow_dvec3(r.x_axis.cross(r.y_axis)),
            stokes_nodes: if opts.stokes_parallels {
                super::parallel_quadrature::node_counts(&a)
            } else {
                [0; 4]
            },
        }
    }

    /// Stokes nodes per segment for the children at `depth` (coarse
    /// depths only), or `None` for chords.
    #[inline]
    pub fn stokes_nodes_at(&self, depth: u32) -> Option<usize> {
        let i = depth.checked_sub(super::parallel_quadrature::FIRST_DEPTH)? as usize;
        self.stokes_nodes
            .get(i)
            .filter(|&&n| n > 0)
            .map(|&n| n as usize)
    }

    /// Normalised density at a unit world direction.
    #[inline]
    pub fn density(&self, w: Vec3) -> f32 {
        let p = transform_rows(&self.rows, w);
        let l2 = p.length_squared();
        if !(l2 > 0.0) {
            return 0.0;
        }
        p.z.max(0.0) * self.det_abs / (PI * l2 * l2)
    }

    /// f64 reference integrals of the 4 children (exact clipping).
    pub fn children_reference(&self, cell: Cell) -> [f32; 4] {
        let o = self.orientation as f64;
        std::array::from_fn(|k| cell_integral_reference(cell.child(k), &self.a64, o) as f32)
    }

    /// Exactly clipped f32 integrals of the 4 children (coarsest levels).
    pub fn children_exact_f32(&self, cell: Cell) -> [f32; 4] {
        exact_children_f32(&self.rows, self.orientation, cell)
    }

    /// Scalar f32 integrals of the 4 children.
    pub fn children_scalar(&self, cell: Cell, deep_depth: u32) -> [f32; 4] {
        let depth = cell.depth + 1;
        if depth <= EXACT_CLIP_DEPTH {
            return level1_children(&self.rows, self.orientation)
                .unwrap_or_else(|| self.children_exact_f32(cell));
        }
        if depth >= deep_depth {
            return self.children_deep(cell);
        }
        if depth >= self.plain_quad_depth {
            quad_children_scalar(self, cell)
        } else if let Some(n) = self.stokes_nodes_at(depth) {
            super::parallel_quadrature::stokes_children_scalar(self, cell, n)
        } else {
            coarse_children_scalar(self, cell)
        }
    }

    /// Integrals from the 4 children's edge sums (2π·F, winding as built):
    /// exact F_z above the horizon, 0 below, and for straddling children
    /// exact clipping at coarse depths (`exact`: 2π·F_z of the clipped
    /// polygons when the caller already clipped them), the sphere
    /// approximation deeper.
    #[inline]
    pub fn finish_children(
        &self,
        cell: Cell,
        sums: [Vec3; 4],
        sides: [HorizonSide; 4],
        exact: Option<[f32; 4]>,
    ) -> [f32; 4] {
        let scale = self.orientation * (0.5 / PI);
        std::array::from_fn(|k| {
            let f = sums[k] * scale;
            match sides[k] {
                HorizonSide::Above => f.z.max(0.0),
                HorizonSide::Below => 0.0,
                HorizonSide::Crossing if cell.depth < self.exact_crossing_depth => match exact {
                    Some(e) => (e[k] * scale).max(0.0),
                    None => {
                        cell_integral_reference(cell.child(k), &self.a64, self.orientation as f64)
                            as f32
                    }
                },
                HorizonSide::Crossing => clipped_integral(f.z, f.length_squared()),
            }
        })
    }

    /// Whether the f32 edge sums `d` of `cell`'s children are rounding
    /// noise: a plain-quad node holding less than [`EDGE_SUM_MIN_MASS`] of
    /// the lobe. Their absolute error is ~2e-9 of the lobe (measured along
    /// the horizon of α = 0.01 at levels 8–12: a node of 3.3e-9 split 0.84
    /// off, one of 1.6e-11 97 off), while density × solid angle keeps its
    /// relative accuracy in the lobe's smooth tail at any mass.
    #[inline]
    pub fn edge_sums_unresolved(&self, cell: Cell, d: [f32; 4]) -> bool {
        let depth = cell.depth + 1;
        depth >= self.plain_quad_depth
            && depth < self.deep_depth
            && (d[0] + d[1]) + (d[2] + d[3]) < EDGE_SUM_MIN_MASS
    }

    /// D(centre)·Ω for the 4 children, as p_z⁺·s/|p|⁴ (see [`Self::deep_scale`]).
    pub fn children_deep(&self, cell: Cell) -> [f32; 4] {
        let s = self.deep_scale(cell.depth + 1);
        child_centre_directions(cell).map(|w| {
            let p = self.rows.map(|m| deep_row(m, w.x, w.y, w.z));
            let l2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
            if !(l2 > 0.0) {
                return 0.0;
            }
            p[2].max(0.0) * s / (l2 * l2)
        })
    }

    /// The deep rule's constant at child depth `depth`: the density
    /// p_z⁺·|det|/(π·|p|⁴) (p = A·ω) times Ω = 4π/4^depth is p_z⁺·s/|p|⁴
    /// with s = |det|·4^(1 − depth), |det| scaled by a power of 2 (exact),
    /// so the chain from p to D carries one product and one division
    /// instead of three products and one division.
    #[inline]
    pub fn deep_scale(&self, depth: u32) -> f32 {
        self.det_abs * f32::from_bits((129u32.saturating_sub(2 * depth.min(63))) << 23)
    }
}

/// One row of the map A applied to a centre direction for the deep rule,
/// its z term first: a centre's height is ready before its radius, which
/// waits on a square root, so the x and y terms end the chain.
#[inline(always)]
pub fn deep_row(m: [f32; 3], x: f32, y: f32, z: f32) -> f32 {
    m[0].mul_add(x, m[1].mul_add(y, m[2] * z))
}

/// Unit directions of the 4 children's centres, in [`Cell::child`] order,
/// for the density × solid angle paths (glossy and diffuse); the wide deep
/// kernel performs the same operations lane by lane.
#[inline]
pub fn child_centre_directions(cell: Cell) -> [Vec3; 4] {
    let (z, _) = child_centres(cell);
    let r = z.map(|z| ((1.0 - z) * (1.0 + z)).max(0.0).sqrt());
    let (s, c) = child_centre_sincos(cell);
    // Height by the u bit (k & 1), azimuth by the v bit (k >> 1).
    std::array::from_fn(|k| {
        let (iu, iv) = (k & 1, k >> 1);
        Vec3::new(r[iu] * c[iv], r[iu] * s[iv], z[iu])
    })
}

/// sin and cos of the children's centre azimuths (by the v bit): the
/// node's centre meridian rotated by half a child's width either way, as in
/// `quad::node_grid` — two table reads and four products, where a sine
/// polynomial would put ~8 dependent FMAs on every deep call's path. The
/// wide twin is `children_x16::centre_sincos_x4`.
#[inline]
pub fn child_centre_sincos(cell: Cell) -> ([f32; 2], [f32; 2]) {
    let (s1, c1) = dyadic_sincos(2 * cell.iy as u64 + 1, cell.depth + 1);
    let (ss, cs) = step_sincos(cell.depth + 2);
    (
        [s1.mul_add(cs, -(c1 * ss)), s1.mul_add(cs, c1 * ss)],
        [c1.mul_add(cs, s1 * ss), c1.mul_add(cs, -(s1 * ss))],
    )
}

/// Exactly clipped integrals of the 4 children under the map `rows`, in f32.
pub fn exact_children_f32(rows: &[[f32; 3]; 3], orientation: f32, cell: Cell) -> [f32; 4] {
    let scale = orientation * (0.5 / PI);
    if let Some(d) = children_x16::clipped_small_children(rows, scale, cell) {
        return d;
    }
    let mut buf = [Vec3::ZERO; MAX_CACHED_POLYGON];
    std::array::from_fn(|k| {
        let n = transformed_cached_polygon(cell.child(k), rows, &mut buf);
        (clipped_edge_sum_z(&buf[..n]) * scale).max(0.0)
    })
}

/// Heights and azimuths (turns) of the 3×3 corner grid of a node's children;
/// exact in f32 down to depth 22.
#[inline]
pub fn child_grid(cell: Cell) -> ([f32; 3], [f32; 3]) {
    let h = 1.0 / (1u64 << (cell.depth + 1)) as f32;
    let (u, w) = ((2 * cell.ix) as f32, (2 * cell.iy) as f32);
    (
        [
            (u * h).mul_add(2.0, -1.0),
            ((u + 1.0) * h).mul_add(2.0, -1.0),
            ((u + 2.0) * h).mul_add(2.0, -1.0),
        ],
        [w * h, (w + 1.0) * h, (w + 2.0) * h],
    )
}

/// Centres of the children: heights (by u bit) and azimuths (by v bit).
#[inline]
pub fn child_centres(cell: Cell) -> ([f32; 2], [f32; 2]) {
    let h = 1.0 / (1u64 << (cell.depth + 2)) as f32;
    let (u, w) = ((4 * cell.ix) as f32, (4 * cell.iy) as f32);
    (
        [
            ((u + 1.0) * h).mul_add(2.0, -1.0),
            ((u + 3.0) * h).mul_add(2.0, -1.0),
        ],
        [(w + 1.0) * h, (w + 3.0) * h],
    )
}

/// The LTC mixture of one shading point.
#[derive(Clone, Debug)]
pub struct ShadingLtc {
    /// Weight of the cosine lobe (diffuse + GGX lobes treated as diffuse).
    pub diffuse_weight: f32,
    /// World normal on the lobes' side (flipped when `Lobes::side` < 0).
    pub normal: Vec3,
    /// World → cosine-space map of the diffuse lobe (f64 reference).
    diffuse_map: DMat3,
    diffuse_rows: [[f32; 3]; 3],
    diffuse_orientation: f32,
    pub glossy: [GlossyLtc; 1],
    pub glossy_count: usize,
    pub cos_theta_o: f32,
    grazing_cos: f32,
    exact_crossing_depth: u32,
    diffuse_centre_depth: u32,
    total: f32,
}

impl ShadingLtc {
    /// `frame` maps world ↔ shading frame; `wo_local` is ω_o in the frame the
    /// lobes were computed in (after two-sided mirroring, as `Lobes` states).
    pub fn new(
        lobes: &Lobes,
        frame: &Frame,
        wo_local: Vec3,
        table: &LtcTable,
        opts: &LtcOptions,
    ) -> Self {
        let side: f64 = if lobes.side < 0.0 { -1.0 } else { 1.0 };
        let to_local = DMat3::from_cols(
            frame.s.as_dvec3(),
            frame.t.as_dvec3(),
            frame.n.as_dvec3() * side,
        )
        .transpose();
        let mut normal = frame.n * side as f32;
        if !(normal.is_finite() && normal.length_squared() > 0.0) {
            record(GuardEvent::LtcNonfinite, 1);
            normal = Vec3::Z;
        }
        let wo = if wo_local.is_finite() {
            wo_local
        } else {
            record(GuardEvent::LtcNonfinite, 1);
            Vec3::Z
        };
        let cos_theta_o = (wo.z / wo.length().max(1e-30)).clamp(0.0, 1.0);
        // cos φ_o and sin φ_o straight from ω_o (no angle needed); φ_o = 0
        // at the pole, where the lobe is isotropic about the normal.
        let rxy = (wo.x as f64)
            .mul_add(wo.x as f64, wo.y as f64 * wo.y as f64)
            .sqrt();
        let (sp, cp) = if rxy > 0.0 {
            (wo.y as f64 / rxy, wo.x as f64 / rxy)
        } else {
            (0.0, 1.0)
        };
        let rot_t = DMat3::from_cols(DVec3::new(cp, -sp, 0.0), DVec3::new(sp, cp, 0.0), DVec3::Z);
        let mut diffuse_weight = guard(lobes.diffuse);
        // Placeholder for unused slots (never read past `glossy_count`).
        let mut glossy = [GlossyLtc {
            weight: 0.0,
            rows: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            a64: DMat3::IDENTITY,
            quad_rows: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            orientation: 1.0,
            det_abs: 1.0,
            short_poly: super::quad::short_poly(1.0),
            short_poly_by_4: super::quad::short_poly_by_4(1.0),
            deep_depth: 64,
            plain_quad_depth: FIRST_PLAIN_QUAD_DEPTH,
            exact_crossing_depth: EXACT_CROSSING_DEPTH,
            cofactor_z: [0.0, 0.0, 1.0],
            stokes_nodes: [0; 4],
        }; 1];
        let mut glossy_count = 0;
        for lobe in lobes.ggx.iter().take(lobes.ggx_count.min(1)) {
            let w = guard(lobe.weight);
            let alpha = if lobe.alpha.is_finite() {
                lobe.alpha
            } else {
                record(GuardEvent::LtcNonfinite, 1);
                1.0
            };
            if w <= 0.0 {
                continue;
            }
            let entry = table.lookup(alpha, cos_theta_o);
            let weight = w * entry.albedo.max(0.0);
            if opts.integrates_as_cosine(alpha) {
                diffuse_weight += weight;
                continue;
            }
            let m_inv = entry.params().inverse_matrix();
            let a = m_inv * rot_t * to_local;
            if !(a.is_finite() && weight > 0.0) {
                continue;
            }
            glossy[glossy_count] = GlossyLtc::from_map(a, weight, opts);
            glossy_count += 1;
        }
        let total = diffuse_weight + glossy[..glossy_count].iter().map(|g| g.weight).sum::<f32>();
        // The diffuse map's rows and winding, without `from_map`'s
        // switch-depth logarithm (the diffuse lobe has no deep switch).
        let diffuse_rows = [0, 1, 2].map(|i| {
            let r = to_local.row(i);
            [r.x as f32, r.y as f32, r.z as f32]
        });
        let diffuse_orientation = if to_local.determinant() < 0.0 {
            -1.0
        } else {
            1.0
        };
        ShadingLtc {
            diffuse_weight,
            normal,
            diffuse_map: to_local,
            diffuse_rows,
            diffuse_orientation,
            glossy,
            glossy_count,
            cos_theta_o,
            grazing_cos: opts.grazing_theta_deg.to_radians().cos(),
            exact_crossing_depth: opts.exact_crossing_depth,
            diffuse_centre_depth: opts.diffuse_centre_depth.max(EXACT_CLIP_DEPTH + 1),
            total: guard(total),
        }
    }

    /// ∫ over the sphere of the mixture: Σ weights × albedos.
    pub fn total(&self) -> f32 {
        self.total
    }

    /// The paper's fallbacks: radiance-only guiding at grazing ω_o, or when
    /// the product vanishes everywhere.
    pub fn prefers_radiance_only(&self) -> bool {
        self.cos_theta_o <= self.grazing_cos || !(self.total > 0.0)
    }

    /// Mixture density (∫ = total) at a unit world direction.
    pub fn density(&self, w: Vec3) -> f32 {
        let mut d = self.diffuse_weight * self.normal.dot(w).max(0.0) / PI;
        for g in &self.glossy[..self.glossy_count] {
            d += g.weight * g.density(w);
        }
        guard(d)
    }

    /// D_k = ∫_{child k of `cell`} (mixture) dω, k in the order of
    /// [`Cell::child`]. Finite and non-negative.
    pub fn child_integrals(&self, cell: Cell, kernel: ProductKernel) -> [f32; 4] {
        let mut out = [0.0f32; 4];
        if !(self.total > 0.0) {
            return out;
        }
        if self.diffuse_weight > 0.0 {
            let d = match kernel {
                ProductKernel::Naive => self.diffuse_reference(cell),
                _ if cell.depth < EXACT_CLIP_DEPTH => self.diffuse_root_children(),
                ProductKernel::Simd if cell.depth + 1 >= self.diffuse_centre_depth => {
                    children_x16::diffuse_centres_x4(self.normal, cell)
                }
                _ if cell.depth + 1 >= self.diffuse_centre_depth => self.diffuse_centres(cell),
                ProductKernel::Simd if cell.depth >= EXACT_CROSSING_DEPTH => {
                    children_x16::diffuse_children_x4(self.normal, cell)
                }
                _ => self.diffuse_form_factors(cell),
            };
            for k in 0..4 {
                out[k] += self.diffuse_weight * d[k];
            }
        }
        for g in &self.glossy[..self.glossy_count] {
            let mut d = match kernel {
                ProductKernel::Naive => g.children_reference(cell),
                ProductKernel::Optimized => g.children_scalar(cell, g.deep_depth),
                ProductKernel::Simd => children_x16::children_x16(g, cell, g.deep_depth),
            };
            if kernel != ProductKernel::Naive && g.edge_sums_unresolved(cell, d) {
                d = g.children_deep(cell);
            }
            for k in 0..4 {
                out[k] += g.weight * d[k];
            }
        }
        guard4(out)
    }
}
