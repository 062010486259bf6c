//! Children with subdivided parallels (depths 2..=5) by Stokes quadrature
//! along the parallels, scalar, and the parts shared with the wide kernel
//! ([`super::parallel_quadrature_x16`]).
//!
//! By Stokes, 2π·F_z of a region is ∮ (ω×dω)_z over its boundary. Mapped
//! into the lobe's cosine space, ω = u/|u| with u = A·c, so a boundary piece
//! c(t) contributes ∫ (u×u')_z/|u|² dt, and (A·c)×(A·c') = cof(A)·(c×c'):
//! along a parallel c(t) = (r cos t, r sin t, z) that is
//! ∫ q·(−z r cos t, −z r sin t, r²) / |A·c(t)|² dt with q = A₀ × A₁ (rows),
//! a smooth integrand with no angle or square root in it. The meridians
//! stay exact great-arc edges. Chords (great arcs between points of the
//! parallel) are exact integrals of the wrong curve; the quadrature is an
//! approximate integral of the right one.
//!
//! The integrand has a near pole where |A·c| is smallest, of width ~ the
//! lobe's angular size, which shrinks with A's condition number κ; a rule
//! of N Gauss–Legendre nodes per child-wide segment is accurate while
//! κ·(segment span)/N stays below [`MAX_NODE_SPACING`] (measured in
//! `examples/stokes_feasibility.rs`: then worse than chords of 1/64 turn in
//! no case, and 10–1000× better in most). N is chosen per lobe and level
//! from κ_F = ‖A‖_F·‖A⁻¹‖_F ≥ κ among 4, 8, 16 and 32; sharper lobes keep
//! the chords ([`super::coarse`]). Both are deterministic functions of
//! (lobe, node), so sampling and pdf agree.
//!
//! The nodes of segments wholly above the horizon come from a table (their
//! cosines and sines and weights, per node azimuth), shared by the node's 3
//! parallels. A segment across the horizon is clipped exactly: u_z(t) =
//! a cos t + b sin t + k vanishes at closed-form t, the segment's parts
//! above it get their own nodes, and the horizon arcs between exit and
//! entry points close the clipped boundary, as for the chord kernels
//! ([`super::parallel_clip`]).

use super::children::{GlossyLtc, child_grid};
use super::fast_math::{PolyLane, RSQRT_FLOOR, rsqrt};
use super::parallel_clip::{finish, meridians_scalar};
use super::polygon::sincos_turns;
use crate::directional::Cell;
use crate::math::gauss_legendre;
use glam::Vec3;
use std::f64::consts::PI;
use std::sync::OnceLock;

/// Largest κ_F × segment span (turns) / nodes per segment.
pub const MAX_NODE_SPACING: f64 = 0.1;
/// The node counts per segment, smallest first.
pub const NODE_COUNTS: [usize; 4] = [4, 8, 16, 32];
/// Child depths that may be coarse (below the exactly clipped level 1,
/// above the first plain-quad depth).
pub const FIRST_DEPTH: u32 = 2;
pub const LAST_DEPTH: u32 = 5;

/// Nodes per segment at each child depth [`FIRST_DEPTH`]..=[`LAST_DEPTH`]
/// for a map A (0: chords), from κ_F = ‖A‖_F·‖A⁻¹‖_F.
pub fn node_counts(a: &glam::DMat3) -> [u8; 4] {
    let kappa = crate::math::frobenius_condition(a);
    std::array::from_fn(|i| {
        let span = 1.0 / (1u64 << (FIRST_DEPTH as usize + i)) as f64;
        NODE_COUNTS
            .iter()
            .find(|&&n| kappa * span / n as f64 <= MAX_NODE_SPACING)
            .map_or(0, |&n| n as u8)
    })
}

/// Lanes a segment of N nodes occupies (at least half a vector, so that
/// two segments of ≤ 8 nodes share one).
#[inline(always)]
pub fn stride(n: usize) -> usize {
    n.max(8)
}

/// Gauss–Legendre nodes and weights on [−1, 1], zero padded to 32.
struct Rule {
    x: [f32; 32],
    w: [f32; 32],
}

fn rule(n: usize) -> &'static Rule {
    static RULES: [OnceLock<Rule>; 4] = [const { OnceLock::new() }; 4];
    let i = NODE_COUNTS
        .iter()
        .position(|&m| m == n)
        .expect("node count");
    RULES[i].get_or_init(|| {
        let (x, w): (Vec<f64>, Vec<f64>) = gauss_legendre(n).into_iter().unzip();
        let mut r = Rule {
            x: [0.0; 32],
            w: [0.0; 32],
        };
        for k in 0..n {
            (r.x[k], r.w[k]) = (x[k] as f32, w[k] as f32);
        }
        r
    })
}

/// Nodes and weights of the n-point rule (zero padded to 32).
pub fn rule_arrays(n: usize) -> (&'static [f32], &'static [f32]) {
    let r = rule(n);
    (&r.x, &r.w)
}

/// The nodes of one coarse node's two segments (its children's azimuth
/// ranges) for one node count: segment j's node i in lane j·stride + i,
/// padding with weight 0. Also the node's 3 meridians (cos, sin).
pub struct NodeTable {
    pub cos: Vec<f32>,
    pub sin: Vec<f32>,
    /// Weight × half the segment's length in radians.
    pub hw: Vec<f32>,
    pub meridian: [(f32, f32); 3],
}

fn build_node_table(depth: u32, iy: u32, n: usize) -> NodeTable {
    let span = 1.0 / (1u64 << (depth + 1)) as f64;
    let (x, w): (Vec<f64>, Vec<f64>) = gauss_legendre(n).into_iter().unzip();
    let s = stride(n);
    let mut t = NodeTable {
        cos: vec![1.0; 2 * s],
        sin: vec![0.0; 2 * s],
        hw: vec![0.0; 2 * s],
        meridian: [(0.0, 0.0); 3],
    };
    for j in 0..2 {
        let mid = (2 * iy + j) as f64 * span + 0.5 * span;
        for i in 0..n {
            let phi = 2.0 * PI * (mid + 0.5 * span * x[i]);
            t.cos[j as usize * s + i] = phi.cos() as f32;
            t.sin[j as usize * s + i] = phi.sin() as f32;
            t.hw[j as usize * s + i] = (w[i] * PI * span) as f32;
        }
    }
    for (c, m) in t.meridian.iter_mut().enumerate() {
        // The chord kernels' corner azimuths, so both see the same corners.
        let (s, co) = sincos_turns((2 * iy + c as u32) as f32 * span as f32);
        *m = (co, s);
    }
    t
}

/// The table of node (depth, iy) for n nodes per segment, built on first use
/// (nodes at depths 1..=4, 30 azimuth ranges × 4 node counts, ~46 KiB).
pub fn node_table(depth: u32, iy: u32, n: usize) -> &'static NodeTable {
    static TABLES: OnceLock<Vec<[OnceLock<NodeTable>; 4]>> = OnceLock::new();
    let tables = TABLES.get_or_init(|| {
        (0..(2u32 << (LAST_DEPTH - 1)))
            .map(|_| [const { OnceLock::new() }; 4])
            .collect()
    });
    debug_assert!((FIRST_DEPTH - 1..LAST_DEPTH).contains(&depth));
    let i = NODE_COUNTS
        .iter()
        .position(|&m| m == n)
        .expect("node count");
    let base = (1usize << depth) - 2;
    tables[base + iy as usize][i].get_or_init(|| build_node_table(depth, iy, n))
}

/// One parallel of the node's 3×3 corner grid, for the integrand
/// q·(c×c')/|A·c|² at c = (r cos t, r sin t, z): u = pc·cos t + ps·sin t +
/// pz, and the numerator kc·cos t + ks·sin t + k0.
#[derive(Clone, Copy, Debug)]
pub struct Parallel {
    pub pc: [f32; 3],
    pub ps: [f32; 3],
    pub pz: [f32; 3],
    pub kc: f32,
    pub ks: f32,
    pub k0: f32,
}

impl Parallel {
    pub fn new(rows: &[[f32; 3]; 3], q: &[f32; 3], z: f32) -> Self {
        // (1 − z)(1 + z) is exact for the grid's dyadic heights; 0 at a pole,
        // where every term then vanishes exactly.
        let r = ((1.0 - z) * (1.0 + z)).sqrt();
        let zr = z * r;
        Parallel {
            pc: std::array::from_fn(|i| r * rows[i][0]),
            ps: std::array::from_fn(|i| r * rows[i][1]),
            pz: std::array::from_fn(|i| z * rows[i][2]),
            kc: -(zr * q[0]),
            ks: -(zr * q[1]),
            k0: (r * r) * q[2],
        }
    }

    /// hw·q·(c×c')/|A·c|² at (cos t, sin t) = (c, s), lane by lane; the
    /// reciprocal is rsqrt², whose scalar and packed forms agree bit for bit.
    #[inline(always)]
    pub fn term<T: PolyLane>(
        &self,
        c: T,
        s: T,
        hw: T,
        rsqrt: impl Fn(T) -> T,
        floor: impl Fn(T) -> T,
    ) -> T {
        let sp = T::splat;
        let u: [T; 3] =
            std::array::from_fn(|i| sp(self.pc[i]).fma(c, sp(self.ps[i]).fma(s, sp(self.pz[i]))));
        let d = u[2].fma(u[2], u[1].fma(u[1], u[0] * u[0]));
        let num = sp(self.kc).fma(c, sp(self.ks).fma(s, sp(self.k0)));
        let y = rsqrt(floor(d));
        (hw * num) * (y * y)
    }

    /// u_z(t) = a cos t + b sin t + k.
    pub(super) fn horizon_coeffs(&self) -> (f64, f64, f64) {
        (self.pc[2] as f64, self.ps[2] as f64, self.pz[2] as f64)
    }

    /// The unit cosine-space direction of the parallel at (cos t, sin t),
    /// projected on the horizon (for crossing points).
    pub(super) fn horizon_point(&self, (c, s): (f64, f64)) -> Vec3 {
        let x = self.pc[0] as f64 * c + self.ps[0] as f64 * s + self.pz[0] as f64;
        let y = self.pc[1] as f64 * c + self.ps[1] as f64 * s + self.pz[1] as f64;
        let l = x.mul_add(x, y * y).sqrt().max(1e-30);
        Vec3::new((x / l) as f32, (y / l) as f32, 0.0)
    }
}

/// Scalar term (the lane operations of [`Parallel::term`] on f32).
#[inline(always)]
pub fn term_scalar(p: &Parallel, c: f32, s: f32, hw: f32) -> f32 {
    p.term(c, s, hw, rsqrt, |d: f32| d.max(RSQRT_FLOOR))
}

/// (s[0..4] + s[4..8]) summed pairwise: the last steps of every lane sum,
/// in the order the wide kernel's halving reductions take.
#[inline(always)]
pub fn reduce8(s: &[f32]) -> f32 {
    let q: [f32; 4] = std::array::from_fn(|l| s[l] + s[l + 4]);
    (q[0] + q[2]) + (q[1] + q[3])
}

/// Sum of 16 lanes: halves first, then [`reduce8`].
#[inline(always)]
pub fn reduce16(v: &[f32]) -> f32 {
    let h: [f32; 8] = std::array::from_fn(|l| v[l] + v[l + 8]);
    reduce8(&h)
}

/// A segment's sum from its terms (lanes j·stride..), in the wide
/// kernel's order: two chunks added lane-wise for 32 nodes, then 16 or 8
/// lanes reduced.
#[inline(always)]
pub fn segment_sum(terms: &[f32], n: usize, j: usize) -> f32 {
    let s = stride(n);
    let t = &terms[j * s..j * s + s];
    match n {
        32 => {
            let v: [f32; 16] = std::array::from_fn(|l| t[l] + t[l + 16]);
            reduce16(&v)
        }
        16 => reduce16(t),
        _ => reduce8(t),
    }
}

/// Quadrature of `p` over [va, vb] (turns) with n nodes placed at run
/// time, lane by lane as the wide kernel does (16 per chunk, chunks added
/// lane-wise, then [`reduce16`]).
pub fn integrate_part_scalar(p: &Parallel, n: usize, va: f32, vb: f32) -> f32 {
    let r = rule(n);
    let (m, h) = (0.5 * (va + vb), 0.5 * (vb - va));
    let hr = h * (2.0 * std::f32::consts::PI);
    let mut acc = [0.0f32; 16];
    for chunk in 0..n.div_ceil(16) {
        for (l, a) in acc.iter_mut().enumerate() {
            let i = 16 * chunk + l;
            let (s, c) = sincos_turns(h.mul_add(r.x[i], m));
            *a += term_scalar(p, c, s, hr * r.w[i]);
        }
    }
    reduce16(&acc)
}

/// The node's 3 parallels.
pub fn parallels(g: &GlossyLtc, z: &[f32; 3]) -> [Parallel; 3] {
    std::array::from_fn(|i| Parallel::new(&g.rows, &g.cofactor_z, z[i]))
}

/// The 4 child integrals of a coarse node by Stokes quadrature, scalar,
/// with `n` nodes per segment.
pub fn stokes_children_scalar(g: &GlossyLtc, cell: Cell, n: usize) -> [f32; 4] {
    let (z, _) = child_grid(cell);
    let table = node_table(cell.depth, cell.iy, n);
    let pars = parallels(g, &z);
    let mut terms = [0.0f32; 64];
    let s: [[f32; 2]; 3] = std::array::from_fn(|row| {
        for (l, t) in terms[..2 * stride(n)].iter_mut().enumerate() {
            *t = term_scalar(&pars[row], table.cos[l], table.sin[l], table.hw[l]);
        }
        [segment_sum(&terms, n, 0), segment_sum(&terms, n, 1)]
    });
    let m = meridians_scalar(g, &z, table);
    finish(g, cell, table, &s, &m, &pars, |row, va, vb| {
        integrate_part_scalar(&pars[row], n, va, vb)
    })
}
