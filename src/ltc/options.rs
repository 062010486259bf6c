//! What a caller chooses about the child integrals: the kernel (the
//! paper's Table 1 variants) and the accuracy switches. The defaults are
//! the accurate API; a guider may relax them (`guiding::product`), since an
//! approximate product costs variance, never bias.

/// Which implementation computes the child integrals.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ProductKernel {
    /// f64, exact horizon clipping, no precomputation, scalar.
    Naive,
    /// Sphere-clipping approximation and precomputed diffuse form factors, scalar f32.
    Optimized,
    /// `Optimized`, 16 lanes wide.
    #[default]
    Simd,
}

#[derive(Clone, Copy, Debug)]
pub struct LtcOptions {
    /// GGX lobes rougher than this are integrated as cosines (paper: 0.5).
    pub rough_as_diffuse_above: f32,
    /// From this θ_o (degrees) on, [`ShadingLtc::prefers_radiance_only`]
    /// tells the guider to drop the product (paper: 85°).
    pub grazing_theta_deg: f32,
    /// A glossy child whose angular size, magnified by the lobe's map,
    /// falls below this (radians in cosine space) gets density × solid angle
    /// instead of an f32 edge sum (measured in `tests/ltc_deep_switch.rs`).
    pub deep_cell_size: f32,
    /// Diffuse children, and glossy plain-quad children, of nodes
    /// shallower than this that straddle the horizon are clipped exactly;
    /// deeper ones (and all of them when this is ≤ 1, level 1 excepted) use
    /// the sphere approximation of their form factor. (Glossy children with
    /// subdivided parallels are always clipped exactly, per edge.) Exact
    /// clipping is the accurate default of the API; a guider may trade it
    /// for speed, since an approximate product costs variance, never bias.
    pub exact_crossing_depth: u32,
    /// Glossy children at this level P or deeper are plain chord quads;
    /// shallower ones (levels 2 to P − 1) follow their parallels with
    /// chords of 1/2^P turn, the width of a plain quad, at 2 to 7 times the
    /// cost. The accurate default of the API is [`FIRST_PLAIN_QUAD_DEPTH`]
    /// (1/64 turn); a guider may lower it, since a chord's error, like the
    /// sphere approximation's, costs variance, never bias.
    pub plain_quad_depth: u32,
    /// Glossy children shallower than the plain-quad depth integrate their
    /// true parallels by Stokes quadrature ([`super::parallel_quadrature`])
    /// when the lobe is broad enough for its node counts, instead of
    /// chords: against the true cells, a mean error 50× and a worst error
    /// 25× below the chords of 1/64 turn (tests/ltc_parallel_quadrature.rs),
    /// but not cheaper (1.2–2.6× the chord kernels' time at levels 2–5 on
    /// the shared 2-core machine), so off by default.
    pub stokes_parallels: bool,
    /// Diffuse children at this level or deeper get n·ω⁺/π at their centre
    /// × Ω, like deep glossy children, instead of their form factors. The
    /// API's default never switches (exact form factors at every level); a
    /// guider may, where the cosine barely varies across a cell.
    pub diffuse_centre_depth: u32,
}

/// Children up to this depth are clipped exactly (in f32 by the fast
/// kernels): the level-1 cells are quarter spheres, far too large for the
/// sphere approximation, and their 5-vertex polygons are cheap.
pub const EXACT_CLIP_DEPTH: u32 = 1;

/// The first level whose cells' parallels are short enough (≤ 1/64 turn)
/// to be replaced by one chord each.
pub const FIRST_PLAIN_QUAD_DEPTH: u32 = 6;

/// Cell size in cosine space below which f32 edge sums are less accurate
/// than D(centre)·Ω (see `tests/ltc_deep_switch.rs`).
pub const DEFAULT_DEEP_CELL_SIZE: f32 = 0.088;

/// Children up to this depth that straddle the horizon are clipped exactly
/// (f64): the sphere approximation is poor for such large polygons.
pub const EXACT_CROSSING_DEPTH: u32 = 5;

impl LtcOptions {
    /// Whether a GGX lobe of roughness `alpha` is integrated as a cosine
    /// (rougher than `rough_as_diffuse_above`; a non-finite α counts as 1).
    pub fn integrates_as_cosine(&self, alpha: f32) -> bool {
        !(alpha.is_finite() && alpha <= self.rough_as_diffuse_above)
    }
}

impl Default for LtcOptions {
    fn default() -> Self {
        LtcOptions {
            rough_as_diffuse_above: 0.5,
            grazing_theta_deg: 85.0,
            deep_cell_size: DEFAULT_DEEP_CELL_SIZE,
            exact_crossing_depth: EXACT_CROSSING_DEPTH,
            plain_quad_depth: FIRST_PLAIN_QUAD_DEPTH,
            stokes_parallels: false,
            diffuse_centre_depth: u32::MAX,
        }
    }
}
