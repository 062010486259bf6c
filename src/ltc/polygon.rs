//! Integrals of a clamped cosine over (transformed) spherical polygons, and
//! the polygons that stand in for the cylindrical cells.
//!
//! A cell's meridians are great arcs, exact under any linear map; its
//! parallels are small circles, replaced by chords (great arcs between
//! points of the parallel). A chord spanning Δφ on a parallel of polar angle
//! θ misses a sliver of relative area ~ sin²θ·cos θ·Δφ²/12, so coarse cells
//! subdivide their parallels until every chord spans at most
//! [`MAX_CHORD_TURNS`] of a turn; the equator is itself a great circle and
//! only needs a midpoint to break the antipodal level-1 corners; the poles
//! are degenerate parallels whose zero-length edges contribute exactly 0.
//!
//! Two integrators:
//! - the f64 **reference** clips the polygon exactly at the horizon
//!   (Sutherland–Hodgman on the great-circle arcs, which are segments
//!   before normalisation) and sums θ·(a×b)_z/|a×b| with the robust angle
//!   θ = atan2(|a×b|, a·b);
//! - the f32 **fast path** returns the unclipped vector form factor
//!   F = Σ θ_e·n̂_e/2π for the sphere-clipping approximation. Its angle uses
//!   the same atan2 evaluated with our own range-reduced polynomial, so the
//!   scalar and 16-wide kernels compute identical lanes.
//!
//! Both integrands are invariant to the lengths of the vertices (θ and n̂
//! only depend on directions), so transformed vertices are never normalised.

use crate::directional::Cell;
use glam::{DMat3, DVec3, Vec3};
use std::f64::consts::PI;

/// Largest φ-span of a chord on a parallel, in turns (2π/64).
pub const MAX_CHORD_TURNS: f64 = 1.0 / 64.0;

/// Number of chords replacing the parallel at height `z` of a cell at `depth`.
pub fn parallel_segments(depth: u32, z: f64) -> usize {
    parallel_chords(depth, z, MAX_CHORD_TURNS)
}

/// Number of chords of at most `chord_turns` each replacing the parallel at
/// height `z` of a cell at `depth`. The equator is a great circle, split
/// only where a cell's corners would otherwise be antipodal.
pub fn parallel_chords(depth: u32, z: f64, chord_turns: f64) -> usize {
    let span = 1.0 / (1u64 << depth.min(62)) as f64;
    if z.abs() >= 1.0 {
        1
    } else if z == 0.0 {
        if span > 0.25 { 2 } else { 1 }
    } else {
        (span / chord_turns).ceil().max(1.0) as usize
    }
}

/// True when no parallel of a cell at this depth is subdivided.
pub fn is_plain_quad_depth(depth: u32) -> bool {
    1.0 / (1u64 << depth.min(62)) as f64 <= MAX_CHORD_TURNS
}

/// The polygon of a cell in world space (f64), counter-clockwise seen from
/// outside: along the lower parallel with increasing φ, up a meridian, back
/// along the upper parallel, down the first meridian.
pub fn cell_polygon_f64(cell: Cell, out: &mut Vec<DVec3>) {
    cell_polygon_chords_f64(cell, MAX_CHORD_TURNS, out);
}

/// [`cell_polygon_f64`] with chords of at most `chord_turns`.
pub fn cell_polygon_chords_f64(cell: Cell, chord_turns: f64, out: &mut Vec<DVec3>) {
    out.clear();
    let b = cell.bounds();
    let dir = |z: f64, phi: f64| {
        let r = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    let parallel_segments = |depth: u32, z: f64| parallel_chords(depth, z, chord_turns);
    let n0 = parallel_segments(cell.depth, b.z0);
    for k in 0..=n0 {
        out.push(dir(b.z0, b.phi0 + (b.phi1 - b.phi0) * k as f64 / n0 as f64));
    }
    let n1 = parallel_segments(cell.depth, b.z1);
    for k in 0..=n1 {
        out.push(dir(b.z1, b.phi1 - (b.phi1 - b.phi0) * k as f64 / n1 as f64));
    }
}

/// Signed ∫ max(0, ω_z)/π dω over the polygon with the given (unnormalised)
/// vertices, clipped exactly at z = 0; positive for counter-clockwise
/// polygons seen from outside.
pub fn clipped_cosine_integral_f64(verts: &[DVec3], scratch: &mut Vec<DVec3>) -> f64 {
    scratch.clear();
    let n = verts.len();
    for i in 0..n {
        let a = verts[i];
        let b = verts[(i + 1) % n];
        if a.z >= 0.0 {
            scratch.push(a);
        }
        if (a.z >= 0.0) != (b.z >= 0.0) {
            // The arc between a and b is the image of the segment [a, b].
            let t = a.z / (a.z - b.z);
            let mut p = a + (b - a) * t;
            p.z = 0.0;
            scratch.push(p);
        }
    }
    let m = scratch.len();
    if m < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..m {
        let a = scratch[i];
        let b = scratch[(i + 1) % m];
        let c = a.cross(b);
        let s = c.length();
        if s > 0.0 {
            sum += s.atan2(a.dot(b)) * c.z / s;
        }
    }
    sum / (2.0 * PI)
}

/// Reference integral of the LTC whose world→cosine map is `a` over a cell:
/// exact clipping, f64, chord polygon. A level-1 cell whose corners ±x̂ map
/// within 1e-9 of the horizon takes the closed form
/// ([`super::quarter_sphere::quarter_sphere_share_f64`]): its clipped
/// polygon then joins two nearly antipodal points on the horizon, and
/// rounding picks the half of the horizon between them (at (A·x̂)_z = 0
/// exactly the four children summed to 0.004–2 of the lobe).
pub fn cell_integral_reference(cell: Cell, a: &DMat3, orientation: f64) -> f64 {
    if cell.depth == 1 && (*a * DVec3::X).z.abs() <= 1e-9 * a.row(2).length() {
        let k = (cell.ix + 2 * cell.iy) as usize;
        if let Some(share) = super::quarter_sphere::quarter_sphere_share_f64(a, k) {
            return share;
        }
    }
    cell_integral_chords(cell, a, orientation, MAX_CHORD_TURNS)
}

/// [`cell_integral_reference`] with chords of at most `chord_turns`: with
/// fine chords (1/4096 turn: a sag of 3e-7 rad) it stands for the true
/// cell, against which the Stokes quadrature of parallels is measured.
pub fn cell_integral_chords(cell: Cell, a: &DMat3, orientation: f64, chord_turns: f64) -> f64 {
    let mut poly = Vec::with_capacity(16);
    let mut scratch = Vec::with_capacity(24);
    cell_polygon_chords_f64(cell, chord_turns, &mut poly);
    for v in poly.iter_mut() {
        *v = *a * *v;
    }
    (orientation * clipped_cosine_integral_f64(&poly, &mut scratch)).max(0.0)
}

/// Coefficients of atan(t)/t ≈ Σ c_k·(t²)^k on t ∈ [0, 1]: our own
/// Chebyshev interpolant in u = t² (degree 9; atan(√u)/√u is analytic with
/// its nearest singularity at u = −1, so the error falls ~5.8× per degree).
/// Measured in f32 Horner: relative error < 9e-8 over [0, 1].
#[allow(clippy::excessive_precision)] // printed from the f64 interpolant
pub const ATAN_COEFFS: [f32; 10] = [
    9.999999972e-01,
    -3.333327629e-01,
    1.999807528e-01,
    -1.426001608e-01,
    1.093234149e-01,
    -8.349724925e-02,
    5.708955519e-02,
    -3.035186404e-02,
    1.048764885e-02,
    -1.701169973e-03,
];

/// atan(t) for t ∈ [0, 1].
#[inline(always)]
pub fn atan_unit(t: f32) -> f32 {
    let u = t * t;
    let mut p = ATAN_COEFFS[9];
    for k in (0..9).rev() {
        p = p.mul_add(u, ATAN_COEFFS[k]);
    }
    t * p
}

/// θ/s with θ = atan2(s, d), for s ≥ 0, in f32, with exactly the operations
/// of the wide kernel. One reciprocal r = 1/(den·s) serves both quotients:
/// t = num/den = num·s·r and 1/s = den·r.
#[inline(always)]
pub fn theta_over_s(s: f32, d: f32) -> f32 {
    // A degenerate (polar) edge has s = 0 and c = 0: keep k finite so that
    // c·k is exactly 0.
    let s = s.max(1e-30);
    let a = d.abs();
    let swap = s > a;
    let num = if swap { a } else { s };
    let den = if swap { s } else { a };
    let r = 1.0 / (den * s).max(1e-37);
    let t = num * s * r;
    let at = atan_unit(t);
    let th = if swap {
        std::f32::consts::FRAC_PI_2 - at
    } else {
        at
    };
    let theta = if d < 0.0 {
        std::f32::consts::PI - th
    } else {
        th
    };
    theta * (den * r)
}

/// atan2(s, d) for s ≥ 0 (a convenience for tests).
pub fn atan2_nonneg(s: f32, d: f32) -> f32 {
    theta_over_s(s, d) * s
}

/// θ_ab·(a×b)/|a×b| for unnormalised a, b; exactly antisymmetric in (a, b)
/// (no fused products), and 0 for a degenerate edge.
#[inline(always)]
pub fn edge_vector(a: Vec3, b: Vec3) -> Vec3 {
    let c = Vec3::new(
        a.y * b.z - a.z * b.y,
        a.z * b.x - a.x * b.z,
        a.x * b.y - a.y * b.x,
    );
    let d = a.x * b.x + a.y * b.y + a.z * b.z;
    let s = (c.x * c.x + c.y * c.y + c.z * c.z).sqrt();
    c * theta_over_s(s, d)
}

/// sin and cos of 2π·v for v ∈ [0, 1], accurate to a few 1e-8 absolute:
/// the quadrant is split off exactly, so no error of 2π·v is amplified.
#[inline(always)]
pub fn sincos_turns(v: f32) -> (f32, f32) {
    let q = v * 4.0;
    let qi = q.floor();
    let x = (q - qi) * std::f32::consts::FRAC_PI_2;
    let (s, c) = sincos_quarter(x);
    let quadrant = qi - (qi * 0.25).floor() * 4.0;
    let (q1, q2, q3) = (quadrant == 1.0, quadrant == 2.0, quadrant == 3.0);
    let sin = if q3 {
        -c
    } else if q2 {
        -s
    } else if q1 {
        c
    } else {
        s
    };
    let cos = if q3 {
        s
    } else if q2 {
        -c
    } else if q1 {
        -s
    } else {
        c
    };
    (sin, cos)
}

/// sin x and cos x for x ∈ [0, π/2] by Taylor series (to x^13 and x^14).
#[inline(always)]
pub fn sincos_quarter(x: f32) -> (f32, f32) {
    let u = x * x;
    let mut s = 1.0 / 6_227_020_800.0f32;
    s = s.mul_add(u, -1.0 / 39_916_800.0);
    s = s.mul_add(u, 1.0 / 362_880.0);
    s = s.mul_add(u, -1.0 / 5040.0);
    s = s.mul_add(u, 1.0 / 120.0);
    s = s.mul_add(u, -1.0 / 6.0);
    s = s.mul_add(u, 1.0);
    let mut c = -1.0 / 87_178_291_200.0f32;
    c = c.mul_add(u, 1.0 / 479_001_600.0);
    c = c.mul_add(u, -1.0 / 3_628_800.0);
    c = c.mul_add(u, 1.0 / 40320.0);
    c = c.mul_add(u, -1.0 / 720.0);
    c = c.mul_add(u, 1.0 / 24.0);
    c = c.mul_add(u, -0.5);
    c = c.mul_add(u, 1.0);
    (x * s, c)
}

/// World direction at height z (exact in f32 for cells up to depth 23) and
/// azimuth v (in turns).
#[inline(always)]
pub fn cell_point_f32(z: f32, v: f32) -> Vec3 {
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = sincos_turns(v);
    Vec3::new(r * c, r * s, z)
}

/// The 3×3 world-to-cosine map applied with the operation order shared by
/// the scalar and wide kernels. `a` is given by rows.
#[inline(always)]
pub fn transform_rows(a: &[[f32; 3]; 3], v: Vec3) -> Vec3 {
    Vec3::new(
        a[0][2].mul_add(v.z, a[0][1].mul_add(v.y, a[0][0] * v.x)),
        a[1][2].mul_add(v.z, a[1][1].mul_add(v.y, a[1][0] * v.x)),
        a[2][2].mul_add(v.z, a[2][1].mul_add(v.y, a[2][0] * v.x)),
    )
}

/// Builds the f32 chord polygon of a cell.
pub fn build_cell_polygon_f32(cell: Cell, out: &mut Vec<Vec3>) {
    out.clear();
    let b = cell.bounds();
    let scale = 1.0 / (1u64 << cell.depth) as f32;
    let v0 = cell.iy as f32 * scale;
    let (z0, z1) = (b.z0 as f32, b.z1 as f32);
    let (r0, r1) = (
        (1.0 - z0 * z0).max(0.0).sqrt(),
        (1.0 - z1 * z1).max(0.0).sqrt(),
    );
    let n0 = parallel_segments(cell.depth, b.z0);
    let n1 = parallel_segments(cell.depth, b.z1);
    // Both parallels usually share their azimuths: one sincos serves two vertices.
    let mut sc = [(0.0f32, 0.0f32); 65];
    let n = n0.max(n1).min(64);
    for (k, e) in sc.iter_mut().enumerate().take(n + 1) {
        *e = sincos_turns(v0 + scale * k as f32 / n as f32);
    }
    let at = |k: usize, m: usize| {
        if m == n {
            sc[k]
        } else {
            sincos_turns(v0 + scale * k as f32 / m as f32)
        }
    };
    for k in 0..=n0 {
        let (s, c) = at(k, n0);
        out.push(Vec3::new(r0 * c, r0 * s, z0));
    }
    for k in (0..=n1).rev() {
        let (s, c) = at(k, n1);
        out.push(Vec3::new(r1 * c, r1 * s, z1));
    }
}

/// Deepest level whose chord polygons are cached (every subdivided polygon
/// lives at depth ≤ 5, since chords span at most 1/64 of a turn).
pub const CACHED_POLYGON_DEPTH: u32 = 5;

struct PolygonCache {
    /// Start of each cell's vertices; cells in level order, then iy·2^d + ix.
    offsets: Vec<u32>,
    verts: Vec<Vec3>,
}

fn polygon_cache() -> &'static PolygonCache {
    static CACHE: std::sync::OnceLock<PolygonCache> = std::sync::OnceLock::new();
    CACHE.get_or_init(|| {
        let mut offsets = vec![0u32];
        let mut verts = Vec::new();
        let mut poly = Vec::new();
        for depth in 0..=CACHED_POLYGON_DEPTH {
            let n = 1u32 << depth;
            for iy in 0..n {
                for ix in 0..n {
                    build_cell_polygon_f32(Cell { depth, ix, iy }, &mut poly);
                    verts.extend_from_slice(&poly);
                    offsets.push(verts.len() as u32);
                }
            }
        }
        PolygonCache { offsets, verts }
    })
}

/// The f32 chord polygon of a cell (any depth), vertices in world space;
/// coarse levels come from a table built once, since their many chords
/// would otherwise cost a sincos each on every call.
pub fn cell_polygon_f32(cell: Cell, out: &mut Vec<Vec3>) {
    if let Some(p) = cached_cell_polygon(cell) {
        out.clear();
        out.extend_from_slice(p);
    } else {
        build_cell_polygon_f32(cell, out);
    }
}

/// Most vertices of a cached (depth ≤ [`CACHED_POLYGON_DEPTH`]) polygon.
pub const MAX_CACHED_POLYGON: usize = 40;

/// The tabulated chord polygon of a cell at depth ≤ [`CACHED_POLYGON_DEPTH`]
/// (no copy, no allocation); `None` deeper.
#[inline]
pub fn cached_cell_polygon(cell: Cell) -> Option<&'static [Vec3]> {
    if cell.depth > CACHED_POLYGON_DEPTH {
        return None;
    }
    let c = polygon_cache();
    let n = 1usize << cell.depth;
    let index = ((1usize << (2 * cell.depth)) - 1) / 3 + cell.iy as usize * n + cell.ix as usize;
    let p = &c.verts[c.offsets[index] as usize..c.offsets[index + 1] as usize];
    debug_assert!(p.len() <= MAX_CACHED_POLYGON);
    Some(p)
}

/// The tabulated polygon of a coarse cell mapped through `rows` into a
/// stack buffer; returns the vertex count.
#[inline]
pub fn transformed_cached_polygon(
    cell: Cell,
    rows: &[[f32; 3]; 3],
    out: &mut [Vec3; MAX_CACHED_POLYGON],
) -> usize {
    let p = cached_cell_polygon(cell).expect("coarse cell");
    let n = p.len().min(MAX_CACHED_POLYGON);
    for (o, v) in out.iter_mut().zip(&p[..n]) {
        *o = transform_rows(rows, *v);
    }
    n
}

/// Room for a polygon's edge components plus one batch of zero padding
/// for the 16-wide edge sum.
const EDGE_CAPACITY: usize = MAX_CACHED_POLYGON + 1 + 16;

/// 2π·F_z of the polygon clipped exactly at z = 0, in f32 (for the large
/// polygons of coarse levels, where f32 has precision to spare): the
/// unclipped edges' z components 16 at a time
/// ([`super::children_x16::edge_z_soa`]), then [`clipped_sum_z_from_edges`].
/// Both the scalar and the wide kernels end up in that one function, so they
/// agree bit for bit. No allocation; at most [`MAX_CACHED_POLYGON`] vertices.
pub fn clipped_edge_sum_z(verts: &[Vec3]) -> f32 {
    let n = verts.len().min(MAX_CACHED_POLYGON);
    let mut x = [0.0f32; EDGE_CAPACITY];
    let mut y = [0.0f32; EDGE_CAPACITY];
    let mut z = [0.0f32; EDGE_CAPACITY];
    for (i, v) in verts[..n].iter().enumerate() {
        x[i] = v.x;
        y[i] = v.y;
        z[i] = v.z;
    }
    if n == 0 {
        return 0.0;
    }
    x[n] = x[0];
    y[n] = y[0];
    z[n] = z[0];
    let mut ez = [0.0f32; EDGE_CAPACITY];
    super::children_x16::edge_z_soa(&x, &y, &z, n, &mut ez);
    clipped_sum_z_from_edges(&x[..n], &y[..n], &z[..n], &ez[..n])
}

/// 2π·F_z of a polygon (structure of arrays, not closed) clipped exactly at
/// z = 0, given `ez[i]`, the z component of its unclipped edge i → i+1.
///
/// The Sutherland–Hodgman output, edge by edge: an edge with both ends at
/// z ≥ 0 survives whole (its `ez` is reused); an edge leaving the upper
/// half-space keeps its part from its start to the crossing point, one
/// entering keeps its part from the crossing point on, and each exit point
/// is joined to the next entry point (cyclically) along the horizon. Only
/// those few partial and horizon edges are evaluated here (scalar), so the
/// clip costs a handful of edges instead of a second pass over the polygon.
pub fn clipped_sum_z_from_edges(x: &[f32], y: &[f32], z: &[f32], ez: &[f32]) -> f32 {
    let n = ez.len();
    let v = |i: usize| Vec3::new(x[i], y[i], z[i]);
    let crossing = |a: Vec3, b: Vec3| {
        let t = a.z / (a.z - b.z);
        let mut p = a + (b - a) * t;
        p.z = 0.0;
        p
    };
    let mut sum = 0.0f32;
    let mut pending_exit: Option<Vec3> = None;
    let mut first_entry: Option<Vec3> = None;
    for i in 0..n {
        let j = if i + 1 == n { 0 } else { i + 1 };
        let (ia, ib) = (z[i] >= 0.0, z[j] >= 0.0);
        match (ia, ib) {
            (true, true) => sum += ez[i],
            (false, false) => {}
            (true, false) => {
                let (a, b) = (v(i), v(j));
                let p = crossing(a, b);
                sum += edge_vector(a, p).z;
                pending_exit = Some(p);
            }
            (false, true) => {
                let (a, b) = (v(i), v(j));
                let p = crossing(a, b);
                match pending_exit.take() {
                    Some(q) => sum += edge_vector(q, p).z,
                    None => first_entry = first_entry.or(Some(p)),
                }
                sum += edge_vector(p, b).z;
            }
        }
    }
    if let (Some(q), Some(p)) = (pending_exit, first_entry) {
        sum += edge_vector(q, p).z;
    }
    sum
}

/// Unclipped F (times 2π) of a polygon whose vertices are already in cosine
/// space, summed edge by edge in order.
pub fn polygon_edge_sum(verts: &[Vec3]) -> Vec3 {
    let n = verts.len();
    let mut f = Vec3::ZERO;
    for i in 0..n {
        f += edge_vector(verts[i], verts[(i + 1) % n]);
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sincos_turns_is_accurate_over_all_quadrants() {
        for i in 0..=4096 {
            let v = i as f32 / 4096.0;
            let (s, c) = sincos_turns(v);
            let phi = 2.0 * std::f64::consts::PI * v as f64;
            assert!((s as f64 - phi.sin()).abs() < 2e-7, "{v}");
            assert!((c as f64 - phi.cos()).abs() < 2e-7, "{v}");
        }
    }

    #[test]
    fn edge_angle_matches_atan2_and_degenerates_to_zero() {
        for &(s, d) in &[
            (0.5f32, 0.8f32),
            (1e-4, 1.0),
            (0.9, -0.3),
            (1.0, 0.0),
            (1e-6, -1.0),
            (3.0, 4.0),
        ] {
            let exact = (s as f64).atan2(d as f64);
            let got = atan2_nonneg(s, d) as f64;
            assert!(
                (got - exact).abs() <= 3e-7 * exact.max(1e-30) + 1e-12,
                "{s} {d}: {got} {exact}"
            );
        }
        assert_eq!(edge_vector(Vec3::Z, Vec3::Z), Vec3::ZERO);
        assert_eq!(edge_vector(Vec3::Z, -Vec3::Z), Vec3::ZERO);
        let a = Vec3::new(0.3, 0.1, 0.9);
        let b = Vec3::new(-0.2, 0.4, 0.8);
        assert_eq!(edge_vector(a, b), -edge_vector(b, a));
    }

    /// The clip from unclipped edges (partial and horizon edges only)
    /// against the f64 Sutherland–Hodgman reference, on mapped coarse cells
    /// that straddle the horizon, sit above it or below it.
    #[test]
    fn clip_from_edges_matches_f64_reference() {
        let mut straddling = 0;
        let mut worst = 0.0f64;
        let mut p64 = Vec::new();
        let mut scratch = Vec::new();
        for trial in 0..200u32 {
            let t = trial as f64;
            // A tilted, sheared, sometimes mirrored map.
            let a = DMat3::from_cols(
                DVec3::new(1.0 + 0.3 * (t * 0.7).sin(), 0.2 * (t * 1.3).cos(), 0.1),
                DVec3::new(-0.1, 0.8 + 0.4 * (t * 0.9).cos(), 0.3 * (t * 0.4).sin()),
                DVec3::new(0.5 * (t * 0.31).sin(), 0.5 * (t * 0.17).cos(), 0.6),
            ) * if trial % 7 == 0 { -1.0 } else { 1.0 };
            let rows = [0, 1, 2].map(|i| {
                let r = a.row(i);
                [r.x as f32, r.y as f32, r.z as f32]
            });
            let depth = 1 + trial % 5;
            let n = 1u32 << depth;
            let cell = Cell {
                depth,
                ix: (trial * 7) % n,
                iy: (trial * 3) % n,
            };
            let mut buf = [Vec3::ZERO; MAX_CACHED_POLYGON];
            let m = transformed_cached_polygon(cell, &rows, &mut buf);
            let got = clipped_edge_sum_z(&buf[..m]) as f64 / (2.0 * PI);
            cell_polygon_f64(cell, &mut p64);
            for v in p64.iter_mut() {
                *v = a * *v;
            }
            let want = clipped_cosine_integral_f64(&p64, &mut scratch);
            let zs = buf[..m].iter().map(|v| v.z);
            if zs.clone().any(|z| z > 0.0) && zs.clone().any(|z| z < 0.0) {
                straddling += 1;
            }
            worst = worst.max((got - want).abs());
            assert!((got - want).abs() <= 2e-5, "{cell:?}: {got} vs {want}");
        }
        assert!(straddling > 40, "{straddling}");
        println!("clip from edges vs f64: worst {worst:.1e}");
    }

    #[test]
    fn level_one_polygon_splits_the_antipodal_equator() {
        let mut p = Vec::new();
        cell_polygon_f64(
            Cell {
                depth: 1,
                ix: 1,
                iy: 0,
            },
            &mut p,
        );
        // (1,0,0), (0,1,0), (−1,0,0) on the equator, then the pole twice.
        assert_eq!(p.len(), 5);
        assert!((p[1] - DVec3::Y).length() < 1e-12);
        let up = clipped_cosine_integral_f64(&p, &mut Vec::new());
        assert!((up - 0.5).abs() < 1e-12, "{up}");
    }
}
