//! Linearly transformed cosines for product path guiding (Diolatzis et al.
//! 2020, §3; Heitz et al. 2016).
//!
//! Product guiding needs, at every level of a quadtree descent, the integral
//! of the cosine-weighted BSDF over each of the 4 children of a node. The
//! BSDF's lobes are approximated by LTCs — clamped cosines pushed through a
//! 3×3 matrix — whose integral over a spherical polygon is the clamped
//! cosine's integral over the polygon mapped back by M⁻¹, a closed-form sum
//! over its edges. The pieces, in the order of the paper:
//!
//! - [`ggx`]: the function being fitted, GGX·cos with Fresnel 1 and
//!   height-correlated Smith G2;
//! - [`fit`]: the Heitz-style fitter behind `ltcguide fit-ltc` (Nelder–Mead
//!   on an MIS-estimated L1 error, warm-started, deterministic);
//! - [`table`]: the 128×128 table over (α, θ_o) committed under `data/`,
//!   with the GGX albedo, and its bilinear lookup;
//! - [`lobe`]: one LTC — density, sampling;
//! - [`polygon`]: the cells as polygons (parallels replaced by chords,
//!   subdivided at coarse levels) and the edge integrals: an f64 reference
//!   with exact horizon clipping and the f32 edge sum of the fast paths;
//! - [`sphere_clip`]: horizon clipping by the sphere approximation (Snyder's
//!   closed form, tabulated);
//! - [`form_factor`]: exact vector form factors of cylindrical cells, the
//!   diffuse lobe's whole cost;
//! - [`children`]: the per-shading-point mixture ([`ShadingLtc`]) and the
//!   4-child integrals of a node — the API the product guider calls;
//! - [`children_x16`]: the same 4 children × 4 edges in one f32x16;
//! - [`lanes`]: that 16-lane type, one zmm register by default, or two
//!   256-bit halves with the `ymm-kernels` feature (for Intel cores, where
//!   512-bit arithmetic lowers the clock of the whole render);
//! - [`level1`] and [`quarter_sphere`]: the root's children, which are
//!   quarter spheres with antipodal corners: exactly clipped triangles from
//!   their mapped vertices, and near the lune (and for the cosine lobe) a
//!   closed form of three arctangents;
//! - [`coarse`] (with its tables, [`coarse_table`], and the wide
//!   [`coarse_x16`]): levels 2–5, whose parallels need several chords, each
//!   vertex mapped once and each edge clipped exactly at the horizon;
//! - [`parallel_quadrature`] (with [`parallel_clip`] and the wide
//!   [`parallel_quadrature_x16`]): an opt-in alternative to the chords at
//!   levels 2–5, Stokes quadrature along the true parallels.
// `!(x > 0.0)` is deliberate throughout: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod children;
pub mod children_x16;
pub mod coarse;
pub mod coarse_table;
pub mod coarse_x16;
pub mod fast_math;
pub mod fit;
pub mod form_factor;
pub mod ggx;
pub mod lanes;
pub mod level1;
pub mod lobe;
pub mod options;
pub mod parallel_clip;
pub mod parallel_quadrature;
pub mod parallel_quadrature_x16;
pub mod polygon;
pub mod quad;
pub mod quad_x16;
pub mod quarter_sphere;
pub mod simd;
#[cfg(all(target_arch = "x86_64", target_feature = "avx2", not(zmm_kernels)))]
mod simd_avx2;
pub mod sphere_clip;
pub mod table;

pub use children::{LtcOptions, ProductKernel, ShadingLtc};
pub use fit::{FitOptions, FitReport, run_fit};
pub use table::LtcTable;
