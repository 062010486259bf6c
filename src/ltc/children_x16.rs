//! The 16-wide child kernel: the 4 children × 4 edges of a node in one
//! f32x16, as in the paper (lane 4k + e is edge e of child k).
//!
//! Every lane builds its two edge endpoints from the node's 3×3 corner grid,
//! maps them into the lobe's cosine space and evaluates θ·(a×b)/|a×b| with
//! the same operations, in the same order, as the scalar kernel
//! ([`super::polygon::edge_vector`]); the per-child sums use the scalar
//! kernel's order, (e0 + e1) + (e2 + e3), so both agree lane for lane.
//! Coarse nodes whose children have subdivided parallels batch their edges
//! 16 at a time; deep nodes use the shared density × solid-angle path.

use super::children::{EXACT_CLIP_DEPTH, GlossyLtc, HorizonSide, child_centres};
use super::polygon::{
    ATAN_COEFFS, cached_cell_polygon, clipped_sum_z_from_edges, is_plain_quad_depth,
};
use crate::directional::Cell;
use glam::Vec3;
use wide::f32x16;

// Corner-grid indices (height, azimuth) of each lane's endpoints a and b.
// Child k = (iu, iv) = (k & 1, k >> 1); its edges run (iu,iv)→(iu,iv+1)→
// (iu+1,iv+1)→(iu+1,iv)→(iu,iv), the winding of the scalar polygons.
const fn lane_tables() -> [[f32; 16]; 4] {
    let mut t = [[0.0f32; 16]; 4];
    let mut k = 0;
    while k < 4 {
        let (iu, iv) = ((k & 1) as f32, (k >> 1) as f32);
        let corners = [
            (iu, iv),
            (iu, iv + 1.0),
            (iu + 1.0, iv + 1.0),
            (iu + 1.0, iv),
        ];
        let mut e = 0;
        while e < 4 {
            let a = corners[e];
            let b = corners[(e + 1) % 4];
            t[0][4 * k + e] = a.0;
            t[1][4 * k + e] = a.1;
            t[2][4 * k + e] = b.0;
            t[3][4 * k + e] = b.1;
            e += 1;
        }
        k += 1;
    }
    t
}
const LANES: [[f32; 16]; 4] = lane_tables();

#[inline(always)]
fn splat(v: f32) -> f32x16 {
    f32x16::splat(v)
}

/// atan on [0, 1] (see [`super::polygon::atan_unit`]).
#[inline(always)]
fn atan_unit(t: f32x16) -> f32x16 {
    let u = t * t;
    let mut p = splat(ATAN_COEFFS[9]);
    for k in (0..9).rev() {
        p = p.mul_add(u, splat(ATAN_COEFFS[k]));
    }
    t * p
}

/// θ/s (see [`super::polygon::theta_over_s`]).
#[inline(always)]
fn theta_over_s(s: f32x16, d: f32x16) -> f32x16 {
    let s = s.fast_max(splat(1e-30));
    let a = d.abs();
    let swap = s.simd_gt(a);
    let num = swap.bitselect(a, s);
    let den = swap.bitselect(s, a);
    let r = splat(1.0) / (den * s).fast_max(splat(1e-37));
    let t = num * s * r;
    let at = atan_unit(t);
    let th = swap.bitselect(splat(std::f32::consts::FRAC_PI_2) - at, at);
    let theta = d
        .simd_lt(splat(0.0))
        .bitselect(splat(std::f32::consts::PI) - th, th);
    theta * (den * r)
}

/// sin, cos of 2π·v (see [`super::polygon::sincos_turns`]).
#[inline(always)]
fn sincos_turns(v: f32x16) -> (f32x16, f32x16) {
    let q = v * splat(4.0);
    let qi = q.floor();
    let x = (q - qi) * splat(std::f32::consts::FRAC_PI_2);
    let u = x * x;
    let mut s = splat(1.0 / 6_227_020_800.0);
    s = s.mul_add(u, splat(-1.0 / 39_916_800.0));
    s = s.mul_add(u, splat(1.0 / 362_880.0));
    s = s.mul_add(u, splat(-1.0 / 5040.0));
    s = s.mul_add(u, splat(1.0 / 120.0));
    s = s.mul_add(u, splat(-1.0 / 6.0));
    s = s.mul_add(u, splat(1.0));
    let s = x * s;
    let mut c = splat(-1.0 / 87_178_291_200.0);
    c = c.mul_add(u, splat(1.0 / 479_001_600.0));
    c = c.mul_add(u, splat(-1.0 / 3_628_800.0));
    c = c.mul_add(u, splat(1.0 / 40320.0));
    c = c.mul_add(u, splat(-1.0 / 720.0));
    c = c.mul_add(u, splat(1.0 / 24.0));
    c = c.mul_add(u, splat(-0.5));
    c = c.mul_add(u, splat(1.0));
    let quadrant = qi - (qi * splat(0.25)).floor() * splat(4.0);
    let q1 = quadrant.simd_eq(splat(1.0));
    let q2 = quadrant.simd_eq(splat(2.0));
    let q3 = quadrant.simd_eq(splat(3.0));
    let sin = q3.bitselect(-c, q2.bitselect(-s, q1.bitselect(c, s)));
    let cos = q3.bitselect(s, q2.bitselect(-c, q1.bitselect(-s, c)));
    (sin, cos)
}

#[inline(always)]
fn transform(rows: &[[f32; 3]; 3], x: f32x16, y: f32x16, z: f32x16) -> [f32x16; 3] {
    let r = |i: usize| {
        splat(rows[i][2]).mul_add(z, splat(rows[i][1]).mul_add(y, splat(rows[i][0]) * x))
    };
    [r(0), r(1), r(2)]
}

/// θ·(a×b)/|a×b| on 16 lanes.
#[inline(always)]
fn edge_vectors(a: [f32x16; 3], b: [f32x16; 3]) -> [f32x16; 3] {
    let cx = a[1] * b[2] - a[2] * b[1];
    let cy = a[2] * b[0] - a[0] * b[2];
    let cz = a[0] * b[1] - a[1] * b[0];
    let d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let s = (cx * cx + cy * cy + cz * cz).sqrt();
    let k = theta_over_s(s, d);
    [cx * k, cy * k, cz * k]
}

#[inline(always)]
fn load16(a: &[f32], i: usize) -> f32x16 {
    f32x16::from(<[f32; 16]>::try_from(&a[i..i + 16]).unwrap())
}

/// `ez[j]` = (θ·(a×b)/|a×b|)_z of the edge (P[j], P[j+1]), j < m, of a
/// polygon in structure-of-arrays form, 16 edges at a time, with the scalar
/// [`super::polygon::edge_vector`]'s operations. The arrays must hold at
/// least 16 entries past m − 1 (`ez` too).
pub fn edge_z_soa(x: &[f32], y: &[f32], z: &[f32], m: usize, ez: &mut [f32]) {
    let mut j = 0;
    while j < m {
        let a = [load16(x, j), load16(y, j), load16(z, j)];
        let b = [load16(x, j + 1), load16(y, j + 1), load16(z, j + 1)];
        ez[j..j + 16].copy_from_slice(&edge_vectors(a, b)[2].to_array());
        j += 16;
    }
}

/// Most vertices of a clipped small polygon: a convex polygon of ≤ 6
/// vertices gains at most 2 crossing points.
const SMALL_CLIP: usize = 8;

/// Exactly clipped integrals (2π·F_z × `scale`, clamped at 0) of the 4
/// children of a node whose children are small polygons (≤ 6 vertices: the
/// level-1 quarter spheres). Each child is clipped at z = 0
/// (Sutherland–Hodgman) into its own 8 lanes of two edge-start/edge-end
/// batches, then all edges are evaluated 16 at a time and each child sums
/// its 8 lanes in order. `None` when a polygon does not fit (the caller then
/// clips polygon by polygon). Shared by the scalar and wide kernels.
pub fn clipped_small_children(rows: &[[f32; 3]; 3], scale: f32, cell: Cell) -> Option<[f32; 4]> {
    let mut a = [[0.0f32; 4 * SMALL_CLIP]; 3];
    let mut b = [[0.0f32; 4 * SMALL_CLIP]; 3];
    for k in 0..4 {
        let poly = cached_cell_polygon(cell.child(k))?;
        let n = poly.len();
        if n > 6 {
            return None;
        }
        let mut v = [Vec3::ZERO; 6];
        for (q, p) in v.iter_mut().zip(poly) {
            *q = super::polygon::transform_rows(rows, *p);
        }
        let mut c = [Vec3::ZERO; SMALL_CLIP];
        let mut m = 0;
        for i in 0..n {
            let (p, q) = (v[i], v[if i + 1 == n { 0 } else { i + 1 }]);
            if p.z >= 0.0 {
                if m == SMALL_CLIP {
                    return None;
                }
                c[m] = p;
                m += 1;
            }
            if (p.z >= 0.0) != (q.z >= 0.0) {
                if m == SMALL_CLIP {
                    return None;
                }
                let t = p.z / (p.z - q.z);
                let mut x = p + (q - p) * t;
                x.z = 0.0;
                c[m] = x;
                m += 1;
            }
        }
        if m < 3 {
            continue;
        }
        for i in 0..m {
            let (p, q) = (c[i], c[if i + 1 == m { 0 } else { i + 1 }]);
            let l = SMALL_CLIP * k + i;
            (a[0][l], a[1][l], a[2][l]) = (p.x, p.y, p.z);
            (b[0][l], b[1][l], b[2][l]) = (q.x, q.y, q.z);
        }
    }
    let mut ez = [0.0f32; 4 * SMALL_CLIP];
    for h in 0..2 {
        let o = 16 * h;
        let pa = [load16(&a[0], o), load16(&a[1], o), load16(&a[2], o)];
        let pb = [load16(&b[0], o), load16(&b[1], o), load16(&b[2], o)];
        ez[o..o + 16].copy_from_slice(&edge_vectors(pa, pb)[2].to_array());
    }
    Some(std::array::from_fn(|k| {
        let e = &ez[SMALL_CLIP * k..SMALL_CLIP * (k + 1)];
        let sum = ((e[0] + e[1]) + (e[2] + e[3])) + ((e[4] + e[5]) + (e[6] + e[7]));
        (sum * scale).max(0.0)
    }))
}

/// World points of the corner grid for lane indices (zi, vi).
#[inline(always)]
fn grid_points(u: f32, w: f32, h: f32, zi: f32x16, vi: f32x16) -> [f32x16; 3] {
    let z = ((splat(u) + zi) * splat(h)).mul_add(splat(2.0), splat(-1.0));
    let v = (splat(w) + vi) * splat(h);
    let r = (splat(1.0) - z * z).fast_max(splat(0.0)).sqrt();
    let (s, c) = sincos_turns(v);
    [r * c, r * s, z]
}

// Lanes 0..9 of the vertex vector hold the corner grid, lane = 3·zi + vi.
const GRID_Z: [f32; 16] = [
    0., 0., 0., 1., 1., 1., 2., 2., 2., 0., 0., 0., 0., 0., 0., 0.,
];
const GRID_V: [f32; 16] = [
    0., 1., 2., 0., 1., 2., 0., 1., 2., 0., 0., 0., 0., 0., 0., 0.,
];

const fn permutation(which: usize) -> [i32; 16] {
    let mut p = [0i32; 16];
    let mut l = 0;
    while l < 16 {
        p[l] = (3.0 * LANES[2 * which][l] + LANES[2 * which + 1][l]) as i32;
        l += 1;
    }
    p
}
/// Grid vertex feeding each lane as edge start (a) and edge end (b).
const PERM_A: [i32; 16] = permutation(0);
const PERM_B: [i32; 16] = permutation(1);

/// Gathers lanes of `v` by constant indices: one vpermps on AVX-512.
#[inline(always)]
fn permute(v: f32x16, idx: &[i32; 16]) -> f32x16 {
    #[cfg(target_feature = "avx512f")]
    {
        use std::arch::x86_64::{__m512, __m512i, _mm512_permutexvar_ps};
        // SAFETY: f32x16 and __m512 are both 64 bytes holding 16 f32, and
        // [i32; 16] and __m512i both 64 bytes; avx512f is enabled at
        // compile time (the cfg above).
        unsafe {
            let vi: __m512i = std::mem::transmute(*idx);
            let vv: __m512 = std::mem::transmute(v);
            std::mem::transmute(_mm512_permutexvar_ps(vi, vv))
        }
    }
    #[cfg(not(target_feature = "avx512f"))]
    {
        let a = v.to_array();
        f32x16::from(std::array::from_fn::<f32, 16, _>(|l| a[idx[l] as usize]))
    }
}

/// Edge sums (2π·F, winding as built) of the 4 plain-quad children: the 9
/// corners are built and transformed once (lanes 0..9), then permuted into
/// the 16 edge-start and edge-end lanes.
pub fn children_edge_sums_x16(g: &GlossyLtc, cell: Cell) -> ([Vec3; 4], [HorizonSide; 4]) {
    let h = 1.0 / (1u64 << (cell.depth + 1)) as f32;
    let (u, w) = ((2 * cell.ix) as f32, (2 * cell.iy) as f32);
    let p = grid_points(u, w, h, f32x16::from(GRID_Z), f32x16::from(GRID_V));
    let t = transform(&g.rows, p[0], p[1], p[2]);
    let ta = [
        permute(t[0], &PERM_A),
        permute(t[1], &PERM_A),
        permute(t[2], &PERM_A),
    ];
    let tb = [
        permute(t[0], &PERM_B),
        permute(t[1], &PERM_B),
        permute(t[2], &PERM_B),
    ];
    // Lanes 4k..4k+3 hold every corner of child k as an edge start.
    let above = ta[2].simd_ge(splat(0.0)).to_bitmask();
    let below = ta[2].simd_le(splat(0.0)).to_bitmask();
    let e = edge_vectors(ta, tb);
    let (x, y, z) = (e[0].to_array(), e[1].to_array(), e[2].to_array());
    let sums = std::array::from_fn(|k| {
        let l = 4 * k;
        Vec3::new(
            (x[l] + x[l + 1]) + (x[l + 2] + x[l + 3]),
            (y[l] + y[l + 1]) + (y[l + 2] + y[l + 3]),
            (z[l] + z[l + 1]) + (z[l + 2] + z[l + 3]),
        )
    });
    let sides =
        std::array::from_fn(|k| HorizonSide::of_masks(above >> (4 * k), below >> (4 * k), 0xF));
    (sums, sides)
}

/// Room for the closed polygons of 4 children at level 2 (4 × 35 points)
/// plus one batch of padding.
const MAX_POINTS: usize = 4 * 35 + 20;

/// Edge sums of children with subdivided parallels. The 4 closed polygons
/// are laid out one after the other in structure-of-arrays form, mapped
/// through A 16 points at a time, and their edges (P[j], P[j+1]) taken 16 at
/// a time with two shifted loads; each child accumulates its own lanes in
/// polygon order, like the scalar kernel.
pub fn children_edge_sums_batched(
    g: &GlossyLtc,
    cell: Cell,
) -> ([Vec3; 4], [HorizonSide; 4], [f32; 4]) {
    let mut p = [[0.0f32; MAX_POINTS]; 3];
    let mut start = [0usize; 5];
    let mut len = 0;
    for (k, s) in start.iter_mut().take(4).enumerate() {
        let poly = cached_cell_polygon(cell.child(k)).expect("coarse cell");
        *s = len;
        for v in poly.iter().chain(std::iter::once(&poly[0])) {
            if len < MAX_POINTS - 17 {
                p[0][len] = v.x;
                p[1][len] = v.y;
                p[2][len] = v.z;
                len += 1;
            }
        }
    }
    start[4] = len;
    // Map every point into cosine space, 16 at a time.
    let mut t = [[0.0f32; MAX_POINTS]; 3];
    let load = |a: &[f32; MAX_POINTS], i: usize| {
        f32x16::from(<[f32; 16]>::try_from(&a[i..i + 16]).unwrap())
    };
    let mut i = 0;
    while i < len {
        let q = transform(&g.rows, load(&p[0], i), load(&p[1], i), load(&p[2], i));
        for c in 0..3 {
            t[c][i..i + 16].copy_from_slice(&q[c].to_array());
        }
        i += 16;
    }
    let mut sums = [Vec3::ZERO; 4];
    let mut ez = [0.0f32; MAX_POINTS];
    let mut j = 0;
    while j + 1 < len {
        let a = [load(&t[0], j), load(&t[1], j), load(&t[2], j)];
        let b = [load(&t[0], j + 1), load(&t[1], j + 1), load(&t[2], j + 1)];
        let e = edge_vectors(a, b);
        let (x, y, z) = (e[0].to_array(), e[1].to_array(), e[2].to_array());
        ez[j..j + 16].copy_from_slice(&z);
        for (k, sum) in sums.iter_mut().enumerate() {
            // Edges of child k start at points start[k]..start[k+1]−1.
            let lo = start[k].max(j);
            let hi = (start[k + 1] - 1).min(j + 16);
            for l in lo..hi {
                *sum += Vec3::new(x[l - j], y[l - j], z[l - j]);
            }
        }
        j += 16;
    }
    let mut sides = [HorizonSide::Above; 4];
    let mut exact = [0.0f32; 4];
    for k in 0..4 {
        let (lo, hi) = (start[k], start[k + 1] - 1);
        let zs = &t[2][lo..hi];
        sides[k] = if zs.iter().all(|&z| z >= 0.0) {
            HorizonSide::Above
        } else if zs.iter().all(|&z| z <= 0.0) {
            HorizonSide::Below
        } else {
            HorizonSide::Crossing
        };
        if sides[k] == HorizonSide::Crossing {
            exact[k] =
                clipped_sum_z_from_edges(&t[0][lo..hi], &t[1][lo..hi], &t[2][lo..hi], &ez[lo..hi]);
        }
    }
    (sums, sides, exact)
}

/// D(centre)·Ω for the 4 children in lanes 0..4, with the scalar
/// [`GlossyLtc::children_deep`]'s operations.
pub fn children_deep_x16(g: &GlossyLtc, cell: Cell) -> [f32; 4] {
    let omega = cell.child(0).solid_angle() as f32;
    let (z, v) = child_centres(cell);
    let zl = f32x16::from(std::array::from_fn::<f32, 16, _>(|l| z[l & 1]));
    let vl = f32x16::from(std::array::from_fn::<f32, 16, _>(|l| v[(l >> 1) & 1]));
    let r = (splat(1.0) - zl * zl).fast_max(splat(0.0)).sqrt();
    let (s, c) = sincos_turns(vl);
    let p = transform(&g.rows, r * c, r * s, zl);
    let l2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    let d = p[2].fast_max(splat(0.0)) * splat(g.det_abs) / (splat(std::f32::consts::PI) * l2 * l2);
    let ok = l2.simd_gt(splat(0.0));
    let out = (ok.bitselect(d, splat(0.0)) * splat(omega)).to_array();
    [out[0], out[1], out[2], out[3]]
}

/// Cosine-lobe integrals of the 4 children of a node at depth ≥ 5, lanes
/// 0..4: the f32 form factors of [`super::form_factor::children_form_factors_f32`]
/// (exact in φ, Gauss in z), then F·n where the equivalent cap clears the
/// horizon. Children next to a pole or straddling the horizon take the
/// scalar route.
pub fn diffuse_children_x16(normal: Vec3, cell: Cell) -> [f32; 4] {
    let n_child = 1u64 << (cell.depth + 1);
    let h = 1.0 / n_child as f32;
    let dz = 2.0 * h;
    let (zc, vc) = child_centres(cell);
    let zl = f32x16::from(std::array::from_fn::<f32, 16, _>(|l| zc[l & 1]));
    let vl = f32x16::from(std::array::from_fn::<f32, 16, _>(|l| vc[(l >> 1) & 1]));
    let off = splat(dz * (0.5 / 3f32.sqrt()));
    let f = |z: f32x16| (splat(1.0) - z * z).fast_max(splat(0.0)).sqrt();
    let g = splat(0.5 * dz) * (f(zl - off) + f(zl + off));
    let x = std::f32::consts::PI * h;
    let x2 = x * x;
    let sh = x * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0));
    let (s, c) = sincos_turns(vl);
    let k2 = g * splat(2.0 * sh * std::f32::consts::FRAC_1_PI);
    let (fx, fy, fz) = (k2 * c, k2 * s, splat(2.0 * h * dz) * zl);
    let dot = fx * splat(normal.x) + fy * splat(normal.y) + fz * splat(normal.z);
    let q = fx * fx + fy * fy + fz * fz;
    let r = dot * dot / q;
    let clear = (r * r).simd_ge(q) & q.simd_gt(splat(0.0));
    let fast = dot.fast_max(splat(0.0)).to_array();
    let mask = clear.to_bitmask();
    std::array::from_fn(|k| {
        let child = cell.child(k);
        let polar = child.ix < 2 || child.ix as u64 >= n_child - 2;
        if mask & (1 << k) != 0 && !polar {
            fast[k]
        } else {
            let f = super::form_factor::form_factor(child);
            super::sphere_clip::clipped_integral(f.dot(normal), f.length_squared())
        }
    })
}

/// The 4 child integrals of a glossy lobe, 16 lanes wide.
pub fn children_x16(g: &GlossyLtc, cell: Cell, deep_depth: u32) -> [f32; 4] {
    let depth = cell.depth + 1;
    if depth <= EXACT_CLIP_DEPTH {
        return g.children_exact_f32(cell);
    }
    if depth >= deep_depth {
        return children_deep_x16(g, cell);
    }
    if is_plain_quad_depth(depth) {
        let (sums, sides) = children_edge_sums_x16(g, cell);
        g.finish_children(cell, sums, sides, None)
    } else {
        let (sums, sides, exact) = children_edge_sums_batched(g, cell);
        g.finish_children(cell, sums, sides, Some(exact))
    }
}
