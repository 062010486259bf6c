//! Horizon clipping for the Stokes quadrature of parallels
//! ([`super::parallel_quadrature`]), shared by its scalar and wide kernels:
//! which parallel segments lie above, below or across the horizon, the
//! exactly clipped parts of those across it, the meridians' per-edge
//! clipping (as in the chord kernels), and the children's sums with their
//! horizon arcs.

use super::children::GlossyLtc;
use super::coarse::{above_part_z, horizon_arc_sum, horizon_point};
use super::parallel_quadrature::{NodeTable, Parallel};
use super::quad::{unit_cosine_vertex, unit_edge};
use crate::directional::Cell;
use glam::Vec3;

/// Where a parallel segment lies with respect to the horizon, and for one
/// across it, the exactly clipped integral and the crossing points.
#[derive(Clone, Copy, Debug, Default)]
pub struct Crossings {
    /// The segment's clipped 2π·F_z contribution (forward).
    pub value: f32,
    /// Crossing points in increasing t (at most 2), with whether the
    /// parallel leaves the upper half-space there (going forward).
    pub count: usize,
    pub points: [Vec3; 2],
    pub exits: [bool; 2],
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SegmentSide {
    Above,
    Below,
    Crossing,
}

/// Classifies segment [v0, v1] (turns, under half a turn; its ends at
/// (cos, sin) `e0`, `e1`) of a parallel whose corner heights (cosine-space
/// z, the meridian kernels' own) have signs `up0`, `up1`: the corners
/// decide the parity of the crossings, the closed-form roots of u_z their
/// positions. `integrate(va, vb)` is the kernel's quadrature over a part
/// above the horizon. Segments wholly above or below are told apart in f32
/// without an angle: u_z = a cos t + b sin t + k has its extremes k ∓ R in
/// the directions ∓(a, b), inside the segment when between its ends.
#[allow(clippy::too_many_arguments)]
pub fn classify_segment(
    p: &Parallel,
    v0: f32,
    v1: f32,
    e0: (f32, f32),
    e1: (f32, f32),
    up0: bool,
    up1: bool,
    integrate: &mut impl FnMut(f32, f32) -> f32,
    crossings: &mut Crossings,
) -> SegmentSide {
    let (a, b, k) = (p.pc[2], p.ps[2], p.pz[2]);
    let between = |x: f32, y: f32| e0.0 * y - e0.1 * x > 0.0 && x * e1.1 - y * e1.0 > 0.0;
    if up0 && up1 && (!between(-a, -b) || k >= 0.0 && k * k >= a.mul_add(a, b * b)) {
        return SegmentSide::Above;
    }
    if !up0 && !up1 && (!between(a, b) || k < 0.0 && k * k > a.mul_add(a, b * b)) {
        return SegmentSide::Below;
    }
    *crossings = crossing_segment(p, v0, v1, e0, e1, up0, up1, integrate);
    SegmentSide::Crossing
}

/// The crossings of a segment across the horizon, without angles: the
/// roots of a·e + k = 0 on the unit circle e = (cos t, sin t) are
/// e = (−k·(a, b) ± √(R² − k²)·(−b, a))/R², ordered along the segment by
/// their sine from its start (segments span at most a quarter turn); only
/// the ends of the parts above the horizon need an azimuth, for their
/// quadrature nodes.
#[cold]
#[allow(clippy::too_many_arguments)]
fn crossing_segment(
    p: &Parallel,
    v0: f32,
    v1: f32,
    e0: (f32, f32),
    e1: (f32, f32),
    up0: bool,
    up1: bool,
    integrate: &mut impl FnMut(f32, f32) -> f32,
) -> Crossings {
    let (a, b, k) = p.horizon_coeffs();
    let (e0, e1) = ((e0.0 as f64, e0.1 as f64), (e1.0 as f64, e1.1 as f64));
    let from_start = |e: (f64, f64)| e0.0 * e.1 - e0.1 * e.0;
    let to_end = |e: (f64, f64)| e.0 * e1.1 - e.1 * e1.0;
    // (order along the segment, direction, azimuth in turns)
    let mut roots = [(0.0f64, (0.0f64, 0.0f64), 0.0f32); 2];
    let mut n = 0;
    let r2 = a.mul_add(a, b * b);
    if r2 > k * k {
        let h = (r2 - k * k).sqrt();
        for sign in [1.0, -1.0] {
            let e = ((-k * a - sign * h * b) / r2, (-k * b + sign * h * a) / r2);
            if from_start(e) > 0.0 && to_end(e) > 0.0 {
                let w = crate::directional::fast_atan2(e.1 as f32, e.0 as f32)
                    * (0.5 / std::f32::consts::PI);
                let v = (w + (0.5 * (v0 + v1) - w).round()).clamp(v0, v1);
                roots[n] = (from_start(e), e, v);
                n += 1;
            }
        }
        if n == 2 && roots[1].0 < roots[0].0 {
            roots.swap(0, 1);
        }
    }
    // The corners' signs are authoritative: a root they contradict lies
    // within rounding of an end, and one they need but the roots miss too.
    if (up0 != up1) != (n % 2 == 1) {
        if n == 0 {
            let uz = |e: (f64, f64)| a.mul_add(e.0, b.mul_add(e.1, k)).abs();
            roots[0] = if uz(e0) < uz(e1) {
                (0.0, e0, v0)
            } else {
                (1.0, e1, v1)
            };
            n = 1;
        } else {
            // Drop the root nearer an end (n is 2 here: one root and equal
            // corner signs leaves it to be dropped alike).
            let near = |r: &(f64, (f64, f64), f32)| from_start(r.1).min(to_end(r.1));
            if n == 2 && near(&roots[1]) >= near(&roots[0]) {
                roots[0] = roots[1];
            }
            n -= 1;
        }
    }
    let mut c = Crossings::default();
    let mut up = up0;
    let mut start = v0;
    for (i, &(_, e, v)) in roots[..n].iter().enumerate() {
        if up {
            c.value += integrate(start, v);
        }
        c.points[i] = p.horizon_point(e);
        c.exits[i] = up;
        up = !up;
        start = v;
    }
    if up {
        c.value += integrate(start, v1);
    }
    c.count = n;
    c
}

/// The node's 6 meridian segments (column c, from row s to s + 1, index
/// 2c + s): z terms whole and above the horizon, corner signs, crossings.
#[derive(Clone, Copy, Debug, Default)]
pub struct Meridians {
    pub ez: [f32; 6],
    pub clip: [f32; 6],
    pub a_up: [bool; 6],
    pub b_up: [bool; 6],
    pub point: [Vec3; 6],
}

/// World corner (row, column) of the node's grid.
#[inline(always)]
pub fn corner(z: &[f32; 3], table: &NodeTable, row: usize, col: usize) -> Vec3 {
    let r = ((1.0 - z[row]) * (1.0 + z[row])).sqrt();
    let (c, s) = table.meridian[col];
    Vec3::new(r * c, r * s, z[row])
}

/// Scalar meridians (the chord kernel's per-edge operations).
pub fn meridians_scalar(g: &GlossyLtc, z: &[f32; 3], table: &NodeTable) -> Meridians {
    let mut m = Meridians::default();
    for e in 0..6 {
        let (col, row) = (e / 2, e % 2);
        let ua = unit_cosine_vertex(&g.rows, corner(z, table, row, col));
        let ub = unit_cosine_vertex(&g.rows, corner(z, table, row + 1, col));
        let (a_up, b_up) = (ua.z >= 0.0, ub.z >= 0.0);
        (m.a_up[e], m.b_up[e]) = (a_up, b_up);
        let (c, k) = unit_edge(ua, ub);
        m.ez[e] = c.z * k;
        m.clip[e] = if a_up != b_up {
            let p = horizon_point(ua, ub);
            m.point[e] = p;
            above_part_z(ua, ub, p, a_up)
        } else if a_up {
            m.ez[e]
        } else {
            0.0
        };
    }
    m
}

/// The corner signs of row `row` (columns 0..3) from the meridians.
#[inline(always)]
fn corner_up(m: &Meridians, row: usize, col: usize) -> bool {
    if row < 2 {
        m.a_up[2 * col + row]
    } else {
        m.b_up[2 * col + 1]
    }
}

/// The 4 child integrals from the tabulated segment sums `s[row][seg]`,
/// the meridians, and `integrate(row, va, vb)`, the kernel's quadrature of
/// part of a parallel (for segments across the horizon).
pub fn finish(
    g: &GlossyLtc,
    cell: Cell,
    table: &NodeTable,
    s: &[[f32; 2]; 3],
    m: &Meridians,
    pars: &[Parallel; 3],
    mut integrate: impl FnMut(usize, f32, f32) -> f32,
) -> [f32; 4] {
    let span = 1.0 / (1u64 << (cell.depth + 1)) as f32;
    let v: [f32; 3] = std::array::from_fn(|c| (2 * cell.iy + c as u32) as f32 * span);
    // Plain loops and a separate crossing store: arrays of the enum with
    // its payload, built by closures, cost store-forwarding stalls that
    // doubled the kernel.
    let mut sides = [[SegmentSide::Above; 2]; 3];
    let mut cross = [[Crossings::default(); 2]; 3];
    for row in 0..3 {
        for j in 0..2 {
            sides[row][j] = classify_segment(
                &pars[row],
                v[j],
                v[j + 1],
                table.meridian[j],
                table.meridian[j + 1],
                corner_up(m, row, j),
                corner_up(m, row, j + 1),
                &mut |va, vb| integrate(row, va, vb),
                &mut cross[row][j],
            );
        }
    }
    let scale = g.orientation * (0.5 / std::f32::consts::PI);
    let mut out = [0.0f32; 4];
    for (k, o) in out.iter_mut().enumerate() {
        let (iu, iv) = (k & 1, k >> 1);
        let (right, left) = (2 * (iv + 1) + iu, 2 * iv + iu);
        let (lower, upper) = (sides[iu][iv], sides[iu + 1][iv]);
        let merid_up = |e: usize| m.a_up[e] && m.b_up[e];
        let merid_down = |e: usize| !m.a_up[e] && !m.b_up[e];
        if lower == SegmentSide::Above
            && upper == SegmentSide::Above
            && merid_up(right)
            && merid_up(left)
        {
            let sum = (s[iu][iv] + m.ez[right]) - (s[iu + 1][iv] + m.ez[left]);
            *o = (sum * scale).max(0.0);
            continue;
        }
        if lower == SegmentSide::Below
            && upper == SegmentSide::Below
            && merid_down(right)
            && merid_down(left)
        {
            continue;
        }
        let val = |side: SegmentSide, tab: f32, c: &Crossings| match side {
            SegmentSide::Above => tab,
            SegmentSide::Below => 0.0,
            SegmentSide::Crossing => c.value,
        };
        let (cl, cu) = (&cross[iu][iv], &cross[iu + 1][iv]);
        let sum = (val(lower, s[iu][iv], cl) + m.clip[right])
            - (val(upper, s[iu + 1][iv], cu) + m.clip[left]);
        let lower_x = (lower == SegmentSide::Crossing).then_some(cl);
        let upper_x = (upper == SegmentSide::Crossing).then_some(cu);
        *o = ((sum + horizon_arcs(lower_x, upper_x, m, right, left)) * scale).max(0.0);
    }
    out
}

/// The horizon arcs of a clipped child, from each point where its boundary
/// leaves the upper half-space to the next one where it re-enters (lower
/// parallel forwards, right meridian, upper parallel backwards, left
/// meridian).
#[cold]
fn horizon_arcs(
    lower: Option<&Crossings>,
    upper: Option<&Crossings>,
    m: &Meridians,
    right: usize,
    left: usize,
) -> f32 {
    let mut events: [(Vec3, bool); 6] = [(Vec3::ZERO, false); 6];
    let mut n = 0;
    let mut push = |p: Vec3, exit: bool| {
        events[n] = (p, exit);
        n += 1;
    };
    if let Some(c) = lower {
        for i in 0..c.count {
            push(c.points[i], c.exits[i]);
        }
    }
    if m.a_up[right] != m.b_up[right] {
        push(m.point[right], m.a_up[right]);
    }
    if let Some(c) = upper {
        for i in (0..c.count).rev() {
            push(c.points[i], !c.exits[i]);
        }
    }
    if m.a_up[left] != m.b_up[left] {
        push(m.point[left], m.b_up[left]);
    }
    horizon_arc_sum(events[..n].iter().copied())
}
