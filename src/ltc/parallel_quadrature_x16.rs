//! Stokes quadrature along parallels, 16 nodes per vector: the scalar
//! [`super::parallel_quadrature`] kernel's lane operations, each tabulated
//! chunk of nodes loaded once for the node's 3 parallels; the 6 meridian
//! segments in one vector; both kernels then share
//! [`super::parallel_clip::finish`].

use super::children::{GlossyLtc, child_grid};
use super::fast_math::{RSQRT_FLOOR, rsqrt_x16};
use super::lanes::f32x16;
use super::parallel_clip::{Meridians, finish};
use super::parallel_quadrature::{NodeTable, Parallel, node_table, parallels, stride};
use super::simd::{
    above_part_z, horizon_points, load16, sincos_turns, splat, spread4, unit_edges, unit_vertices,
};
use crate::directional::Cell;
use glam::Vec3;
use wide::{f32x4, f32x8};

#[inline(always)]
fn term_x16(p: &Parallel, c: f32x16, s: f32x16, hw: f32x16) -> f32x16 {
    p.term(c, s, hw, rsqrt_x16, |d: f32x16| {
        d.fast_max(splat(RSQRT_FLOOR))
    })
}

/// [`super::parallel_quadrature::reduce8`] of 8 lanes.
#[inline(always)]
fn reduce8(v: f32x8) -> f32 {
    // SAFETY: f32x8 is 32 bytes of 8 f32 in lane order, [f32x4; 2] the
    // same bytes split in halves.
    let [lo, hi]: [f32x4; 2] = unsafe { std::mem::transmute(v) };
    let q = (lo + hi).to_array();
    (q[0] + q[2]) + (q[1] + q[3])
}

/// The halves of 16 lanes.
#[inline(always)]
fn halves(v: f32x16) -> [f32x8; 2] {
    // SAFETY: f32x16 is 64 bytes of 16 f32 in lane order, [f32x8; 2] the
    // same bytes split in halves.
    unsafe { std::mem::transmute(v) }
}

/// The two segment sums of one parallel, in the scalar kernel's order.
#[inline(always)]
fn segment_sums(p: &Parallel, t: &NodeTable, n: usize) -> [f32; 2] {
    let chunk = |o: usize| term_x16(p, load16(&t.cos, o), load16(&t.sin, o), load16(&t.hw, o));
    match n {
        32 => std::array::from_fn(|j| {
            let [lo, hi] = halves(chunk(32 * j) + chunk(32 * j + 16));
            reduce8(lo + hi)
        }),
        16 => std::array::from_fn(|j| {
            let [lo, hi] = halves(chunk(16 * j));
            reduce8(lo + hi)
        }),
        _ => halves(chunk(0)).map(reduce8),
    }
}

/// The 6 meridian segments in lanes 0..6, with the scalar
/// [`super::parallel_clip::meridians_scalar`]'s operations.
fn meridians_x16(g: &GlossyLtc, z: &[f32; 3], t: &NodeTable) -> Meridians {
    // Lane e = 2·column + row: its start at (row, column), its end a row up,
    // spread from 4-lane rows and columns (the scalar `corner`'s products).
    const A_ROW: [i32; 16] = [0, 1, 0, 1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0];
    const B_ROW: [i32; 16] = [1, 2, 1, 2, 1, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0];
    const COL: [i32; 16] = [0, 0, 1, 1, 2, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0];
    let r = z.map(|z| ((1.0 - z) * (1.0 + z)).sqrt());
    let four = |v: [f32; 3]| f32x4::from([v[0], v[1], v[2], 0.0]);
    let (rv, zv) = (four(r), four(*z));
    let cv = four(t.meridian.map(|m| m.0));
    let sv = four(t.meridian.map(|m| m.1));
    let (c, s) = (spread4(cv, &COL), spread4(sv, &COL));
    let (ra, rb) = (spread4(rv, &A_ROW), spread4(rv, &B_ROW));
    let ua = unit_vertices(&g.rows, ra * c, ra * s, spread4(zv, &A_ROW));
    let ub = unit_vertices(&g.rows, rb * c, rb * s, spread4(zv, &B_ROW));
    let zero = splat(0.0);
    let (a_up, b_up) = (ua[2].simd_ge(zero), ub[2].simd_ge(zero));
    let (c, k) = unit_edges(ua, ub);
    let ez = c[2] * k;
    let both = a_up & b_up;
    let mut clip = both.bitselect(ez, zero);
    let crossing = a_up ^ b_up;
    let cross_bits = crossing.to_bitmask() & 0x3F;
    let mut px = [0.0f32; 16];
    let mut py = [0.0f32; 16];
    if cross_bits != 0 {
        let p = horizon_points(ua, ub);
        px = p[0].to_array();
        py = p[1].to_array();
        clip = crossing.bitselect(above_part_z(ua, ub, p, a_up), clip);
    }
    let (ez, clip) = (ez.to_array(), clip.to_array());
    let (au, bu) = (a_up.to_bitmask(), b_up.to_bitmask());
    let mut m = Meridians::default();
    for e in 0..6 {
        m.ez[e] = ez[e];
        m.clip[e] = clip[e];
        m.a_up[e] = au >> e & 1 == 1;
        m.b_up[e] = bu >> e & 1 == 1;
        if cross_bits >> e & 1 == 1 {
            m.point[e] = Vec3::new(px[e], py[e], 0.0);
        }
    }
    m
}

/// [`super::parallel_quadrature::integrate_part_scalar`] on 16 lanes.
fn integrate_part_x16(p: &Parallel, n: usize, va: f32, vb: f32) -> f32 {
    let r = super::parallel_quadrature::rule_arrays(n);
    let (m, h) = (0.5 * (va + vb), 0.5 * (vb - va));
    let hr = h * (2.0 * std::f32::consts::PI);
    let mut acc = splat(0.0);
    for chunk in 0..n.div_ceil(16) {
        let x = load16(r.0, 16 * chunk);
        let w = load16(r.1, 16 * chunk);
        let (s, c) = sincos_turns(splat(h).mul_add(x, splat(m)));
        acc += term_x16(p, c, s, splat(hr) * w);
    }
    let [lo, hi] = halves(acc);
    reduce8(lo + hi)
}

/// The 4 child integrals of a coarse node by Stokes quadrature, 16 nodes
/// at a time, `n` nodes per segment.
pub fn stokes_children_x16(g: &GlossyLtc, cell: Cell, n: usize) -> [f32; 4] {
    let (z, _) = child_grid(cell);
    let table = node_table(cell.depth, cell.iy, n);
    debug_assert!(table.cos.len() >= 2 * stride(n));
    let pars = parallels(g, &z);
    let s: [[f32; 2]; 3] = std::array::from_fn(|row| segment_sums(&pars[row], table, n));
    let m = meridians_x16(g, &z, table);
    finish(g, cell, table, &s, &m, &pars, |row, va, vb| {
        integrate_part_x16(&pars[row], n, va, vb)
    })
}
