//! Feasibility of Stokes quadrature along parallels (prototype, f64): the
//! clipped LTC integral of the children at levels 2–5 by exact meridian
//! edges + quadrature of (u×u')_z/|u|² along the parallels, against a
//! fine-chord f64 reference, next to the chord polygons at P = 4 and 6 and
//! the single chord per cell edge that a plain-quad kernel takes.
#![allow(clippy::needless_range_loop)] // k indexes refs and the children alike

use glam::{DMat3, DVec3, Vec3};
use ltcguide::bsdf::{GgxLobe, Lobes};
use ltcguide::directional::Cell;
use ltcguide::ltc::children::{LtcOptions, ShadingLtc};
use ltcguide::ltc::polygon::clipped_cosine_integral_f64;
use ltcguide::ltc::table::LtcTable;
use ltcguide::math::{Frame, gauss_legendre};
use std::f64::consts::PI;

#[derive(Clone, Copy)]
enum Rule {
    Chords(u32),
    /// One chord per cell edge (the plain quad of the deep levels).
    OneChord,
    Gl(usize),
    /// N ∈ {4,8,16,32} by κ_F·span/N ≤ x (chords P=6 when none fits).
    Adapt(f64),
    /// GL in s after t = t* + w·tan s (t*, w from the parallel's D(t)).
    Tan(usize),
    /// Tan with t* = the lobe's azimuth and w from D at t* (cheap, no search).
    TanCheap(usize),
}

struct Lobe {
    a: DMat3,
    q: DVec3,
    orient: f64,
    peak_phi: f64,
}

fn dir(z: f64, phi: f64) -> DVec3 {
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn chord_integral(cell: Cell, a: &DMat3, orient: f64, turns: f64) -> f64 {
    let b = cell.bounds();
    let span = (b.phi1 - b.phi0) / (2.0 * PI);
    let n = (span / turns).ceil().max(1.0) as usize;
    let mut poly = Vec::new();
    for k in 0..=n {
        poly.push(*a * dir(b.z0, b.phi0 + (b.phi1 - b.phi0) * k as f64 / n as f64));
    }
    for k in 0..=n {
        poly.push(*a * dir(b.z1, b.phi1 - (b.phi1 - b.phi0) * k as f64 / n as f64));
    }
    (orient * clipped_cosine_integral_f64(&poly, &mut Vec::new())).max(0.0)
}

fn arc_z(a: DVec3, b: DVec3) -> f64 {
    let c = a.cross(b);
    let s = c.length();
    if s > 0.0 {
        s.atan2(a.dot(b)) * c.z / s
    } else {
        0.0
    }
}

/// ∫ (u×u')_z/|u|² dt over [ta, tb] on the parallel (z0, r).
fn parallel_piece(l: &Lobe, z0: f64, ta: f64, tb: f64, rule: Rule, gl: &[(f64, f64)]) -> f64 {
    let r = (1.0 - z0 * z0).max(0.0).sqrt();
    let f = |t: f64| {
        let c = DVec3::new(r * t.cos(), r * t.sin(), z0);
        let cc = DVec3::new(-z0 * r * t.cos(), -z0 * r * t.sin(), r * r);
        l.q.dot(cc) / (l.a * c).length_squared()
    };
    let d = |t: f64| (l.a * DVec3::new(r * t.cos(), r * t.sin(), z0)).length_squared();
    match rule {
        Rule::Gl(_) | Rule::Chords(_) | Rule::OneChord | Rule::Adapt(_) => {
            let (m, h) = (0.5 * (ta + tb), 0.5 * (tb - ta));
            gl.iter().map(|&(x, w)| w * h * f(m + h * x)).sum()
        }
        Rule::Tan(_) | Rule::TanCheap(_) => {
            let (lo, hi) = (ta.min(tb), ta.max(tb));
            let ts = match rule {
                Rule::Tan(_) => {
                    // argmin D on the full circle by scan + golden refine.
                    let mut best = (f64::MAX, 0.0);
                    for i in 0..720 {
                        let t = 2.0 * PI * i as f64 / 720.0;
                        best = best.min_by_key_f(d(t), t);
                    }
                    let (mut x0, mut x1) = (best.1 - 0.01, best.1 + 0.01);
                    for _ in 0..80 {
                        let m1 = x0 + 0.382 * (x1 - x0);
                        let m2 = x0 + 0.618 * (x1 - x0);
                        if d(m1) < d(m2) { x1 = m2 } else { x0 = m1 }
                    }
                    0.5 * (x0 + x1)
                }
                _ => l.peak_phi,
            };
            // The copy of t* nearest the interval.
            let mid = 0.5 * (lo + hi);
            let ts = ts + 2.0 * PI * ((mid - ts) / (2.0 * PI)).round();
            let h = 1e-4;
            let d2 = (d(ts + h) - 2.0 * d(ts) + d(ts - h)) / (h * h);
            let w = (2.0 * d(ts) / d2.max(1e-300)).sqrt().max(1e-9);
            let (s0, s1) = (((lo - ts) / w).atan(), ((hi - ts) / w).atan());
            let (m, hh) = (0.5 * (s0 + s1), 0.5 * (s1 - s0));
            let v: f64 = gl
                .iter()
                .map(|&(x, wt)| {
                    let s = m + hh * x;
                    let c = s.cos();
                    wt * hh * w / (c * c) * f(ts + w * s.tan())
                })
                .sum();
            if tb >= ta { v } else { -v }
        }
    }
}

/// Clipped integral of a cell by Stokes: meridians exact, parallels by `rule`.
fn stokes_cell(l: &Lobe, cell: Cell, rule: Rule, gl: &[(f64, f64)]) -> f64 {
    let b = cell.bounds();
    let mut sum = 0.0;
    let mut events: Vec<(bool, DVec3)> = Vec::new(); // (exit?, point)
    // Pieces in winding order.
    let ar = &l.a;
    let row2 = DVec3::new(ar.x_axis.z, ar.y_axis.z, ar.z_axis.z);
    let parallel = |z0: f64, ta: f64, tb: f64, sum: &mut f64, ev: &mut Vec<(bool, DVec3)>| {
        let r = (1.0 - z0 * z0).max(0.0).sqrt();
        if r == 0.0 {
            return;
        }
        let uz = |t: f64| r * (row2.x * t.cos() + row2.y * t.sin()) + row2.z * z0;
        let rr = r * row2.x.hypot(row2.y);
        let k = row2.z * z0;
        let psi = row2.y.atan2(row2.x);
        let mut cuts = vec![];
        if rr > k.abs() + 1e-12 * row2.length() {
            let ac = (-k / rr).acos();
            for base in [psi + ac, psi - ac] {
                for m in -3..=3 {
                    let t = base + 2.0 * PI * m as f64;
                    if t > ta.min(tb) && t < ta.max(tb) {
                        cuts.push(t);
                    }
                }
            }
        }
        cuts.sort_by(|x, y| x.total_cmp(y));
        if tb < ta {
            cuts.reverse();
        }
        let mut pts = vec![ta];
        pts.extend(&cuts);
        pts.push(tb);
        for w in pts.windows(2) {
            if uz(0.5 * (w[0] + w[1])) >= -1e-12 * row2.length() {
                *sum += parallel_piece(l, z0, w[0], w[1], rule, gl);
            }
        }
        for &t in &cuts {
            let p = *ar * DVec3::new(r * t.cos(), r * t.sin(), z0);
            let p = DVec3::new(p.x, p.y, 0.0).normalize();
            let dt = if tb > ta { 1e-9 } else { -1e-9 };
            ev.push((uz(t + dt) < 0.0, p));
        }
    };
    let arc = |a: DVec3, bb: DVec3, sum: &mut f64, ev: &mut Vec<(bool, DVec3)>| {
        let (a, bb) = (*ar * a, *ar * bb);
        match (a.z >= 0.0, bb.z >= 0.0) {
            (true, true) => *sum += arc_z(a, bb),
            (false, false) => {}
            (up, _) => {
                let t = a.z / (a.z - bb.z);
                let mut p = a + (bb - a) * t;
                p.z = 0.0;
                if up {
                    *sum += arc_z(a, p);
                } else {
                    *sum += arc_z(p, bb);
                }
                ev.push((up, p.normalize()));
            }
        }
    };
    parallel(b.z0, b.phi0, b.phi1, &mut sum, &mut events);
    arc(dir(b.z0, b.phi1), dir(b.z1, b.phi1), &mut sum, &mut events);
    parallel(b.z1, b.phi1, b.phi0, &mut sum, &mut events);
    arc(dir(b.z1, b.phi0), dir(b.z0, b.phi0), &mut sum, &mut events);
    // Horizon arcs exit → next entry, cyclically.
    if !events.is_empty() {
        let n = events.len();
        let start = events.iter().position(|e| e.0);
        if let Some(s) = start {
            for i in 0..n {
                let (ex, p) = events[(s + i) % n];
                if ex {
                    let (_, q) = events[(s + i + 1) % n];
                    sum += arc_z(p, q);
                }
            }
        }
    }
    (l.orient * sum / (2.0 * PI)).max(0.0)
}

trait MinBy {
    fn min_by_key_f(self, v: f64, t: f64) -> Self;
}
impl MinBy for (f64, f64) {
    fn min_by_key_f(self, v: f64, t: f64) -> Self {
        if v < self.0 { (v, t) } else { self }
    }
}

fn main() {
    let table = LtcTable::load_default().unwrap();
    let opts = LtcOptions {
        rough_as_diffuse_above: 10.0,
        ..LtcOptions::default()
    };
    let frames = [
        Vec3::new(0.3, -0.5, 0.8),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.9, 0.1, 0.2),
        Vec3::new(-0.4, 0.7, -0.3),
    ]
    .map(|n| Frame::from_normal(n.normalize()));
    let args: Vec<String> = std::env::args().collect();
    let rules: Vec<(String, Rule)> = vec![
        ("one chord".into(), Rule::OneChord),
        ("chords P=4".into(), Rule::Chords(4)),
        ("chords P=6".into(), Rule::Chords(6)),
        ("GL4".into(), Rule::Gl(4)),
        ("GL8".into(), Rule::Gl(8)),
        ("GL16".into(), Rule::Gl(16)),
        ("tan8".into(), Rule::Tan(8)),
        ("tancheap8".into(), Rule::TanCheap(8)),
        ("A.10".into(), Rule::Adapt(0.10)),
        ("A.15".into(), Rule::Adapt(0.15)),
        ("A.20".into(), Rule::Adapt(0.20)),
    ];
    let levels: Vec<u32> = if args.len() > 1 {
        args[1].split(',').map(|s| s.parse().unwrap()).collect()
    } else {
        vec![2, 3, 4, 5]
    };
    println!("alpha theta level | method: max, mean of |err|/max(parent, 1e-3)");
    for &alpha in &[1e-3f32, 0.01, 0.1, 0.3, 1.0] {
        let lobes = Lobes {
            diffuse: 0.0,
            ggx: [GgxLobe { weight: 1.0, alpha }],
            ggx_count: 1,
            delta: 0.0,
            side: 1.0,
        };
        for &theta in &[0.0f64, 45.0, 80.0, 89.9] {
            let t = theta.to_radians();
            let wo = Vec3::new(
                (t.sin() * 0.7f64.cos()) as f32,
                (t.sin() * 0.7f64.sin()) as f32,
                t.cos() as f32,
            );
            for &level in &levels {
                let mut stats = vec![(0.0f64, 0.0f64, 0usize); rules.len()];
                for frame in &frames {
                    let s = ShadingLtc::new(&lobes, frame, wo, &table, &opts);
                    let g = s.glossy[0];
                    let kf = ltcguide::math::frobenius_condition(&g.a64);
                    let pk = g.a64.inverse() * DVec3::Z;
                    let l = Lobe {
                        a: g.a64,
                        q: {
                            let r = g.a64.transpose();
                            r.x_axis.cross(r.y_axis)
                        },
                        orient: g.orientation as f64,
                        peak_phi: pk.y.atan2(pk.x),
                    };
                    let depth = level - 1;
                    let n = 1u32 << depth;
                    for ix in 0..n {
                        for iy in 0..n {
                            let node = Cell { depth, ix, iy };
                            let refs: [f64; 4] = std::array::from_fn(|k| {
                                chord_integral(node.child(k), &g.a64, l.orient, 1.0 / 4096.0)
                            });
                            let parent = refs.iter().sum::<f64>().max(1e-3);
                            for (ri, (_, rule)) in rules.iter().enumerate() {
                                let span = 1.0 / (1u64 << level) as f64;
                                let rule = &match rule {
                                    Rule::Adapt(x) => [4usize, 8, 16, 32]
                                        .iter()
                                        .find(|&&n| kf * span / n as f64 <= *x)
                                        .map(|&n| Rule::Gl(n))
                                        .unwrap_or(Rule::Chords(6)),
                                    Rule::OneChord => Rule::Chords(level),
                                    r => *r,
                                };
                                let gl = match rule {
                                    Rule::Gl(n) | Rule::Tan(n) | Rule::TanCheap(n) => {
                                        gauss_legendre(*n)
                                    }
                                    _ => vec![],
                                };
                                for k in 0..4 {
                                    let got = match rule {
                                        Rule::Chords(p) => chord_integral(
                                            node.child(k),
                                            &g.a64,
                                            l.orient,
                                            1.0 / (1u64 << p) as f64,
                                        ),
                                        Rule::Adapt(_) | Rule::OneChord => unreachable!(),
                                        _ => stokes_cell(&l, node.child(k), *rule, &gl),
                                    };
                                    let e = (got - refs[k]).abs() / parent;
                                    let st = &mut stats[ri];
                                    st.0 = st.0.max(e);
                                    st.1 += e;
                                    st.2 += 1;
                                }
                            }
                        }
                    }
                }
                let cond = {
                    let a = ShadingLtc::new(&lobes, &frames[0], wo, &table, &opts).glossy[0].a64;
                    let q = a.transpose() * a;
                    // power iteration for max and min eigenvalues
                    let mut v = DVec3::ONE.normalize();
                    for _ in 0..200 {
                        v = (q * v).normalize();
                    }
                    let lmax = v.dot(q * v);
                    let qi = q.inverse();
                    let mut v = DVec3::ONE.normalize();
                    for _ in 0..200 {
                        v = (qi * v).normalize();
                    }
                    let lmin = 1.0 / v.dot(qi * v);
                    (lmax / lmin).sqrt()
                };
                let kf = ltcguide::math::frobenius_condition(
                    &ShadingLtc::new(&lobes, &frames[0], wo, &table, &opts).glossy[0].a64,
                );
                print!("{alpha:<6} {theta:>4} L{level} c{cond:<7.1} kF{kf:<7.1}|");
                for (ri, (name, _)) in rules.iter().enumerate() {
                    let st = stats[ri];
                    print!(" {name}: {:.1e} {:.1e} |", st.0, st.1 / st.2 as f64);
                }
                println!();
            }
        }
    }
}
