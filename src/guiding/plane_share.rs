//! The share of a quadtree cell above a plane through the origin: which
//! side of the plane a cell lies on, exactly, and the fraction of its
//! square (cylindrical) measure above it, by a midpoint rule in azimuth
//! and the exact crossing height along each sampled meridian. The
//! hemisphere weights ([`super::support`]) multiply each child's radiance
//! by it.

use crate::directional::Cell;
use glam::Vec3;

/// Where a cell lies against a plane through the origin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Side {
    Above,
    Below,
    Straddles,
}

/// Azimuth samples of the share's midpoint rule in a straddling cell: more
/// in the quarter and sixteenth turns of depths 1–2, which every vertex
/// computes (once, see [`HemisphereWeights`]), than deeper.
const COARSE_AZIMUTH_SAMPLES: usize = 8;
const AZIMUTH_SAMPLES: usize = 4;
const COARSE_DEPTH: u32 = 2;

/// Azimuths are handled as integers m, the angle m·2⁻²³ of a turn: every
/// cell bound down to depth 20 and the midpoint rule's 4 samples in it are
/// such angles exactly.
const TURN_BITS: u32 = 23;

/// (sin, cos) of m·2⁻²³ turn. The reduction to an octant is exact (integer
/// arithmetic), and the Taylor polynomials on [0, π/4] are within 3e-7.
/// A cell's share is computed at up to 11 azimuths; libm's sinf and cosf
/// made hemisphere weights cost more than the rest of the guided render.
#[inline]
fn turn_sin_cos(m: u32) -> (f32, f32) {
    const OCTANT_BITS: u32 = TURN_BITS - 3;
    let m = m & ((1 << TURN_BITS) - 1);
    let octant = m >> OCTANT_BITS;
    let r = m & ((1 << OCTANT_BITS) - 1);
    // Odd octants measure their angle from the octant's far end.
    let r = if octant & 1 == 1 {
        (1 << OCTANT_BITS) - r
    } else {
        r
    };
    let u = r as f32 * (std::f32::consts::FRAC_PI_4 / (1 << OCTANT_BITS) as f32);
    let u2 = u * u;
    let s = u * (1.0 - u2 / 6.0 * (1.0 - u2 / 20.0 * (1.0 - u2 / 42.0)));
    let c = 1.0 - u2 / 2.0 * (1.0 - u2 / 12.0 * (1.0 - u2 / 30.0 * (1.0 - u2 / 56.0)));
    // Within the quadrant: odd octants swap sine and cosine.
    let (s, c) = if octant & 1 == 1 { (c, s) } else { (s, c) };
    match octant >> 1 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// The plane's normal with its azimuthal part, as the per-cell tests use it.
#[derive(Clone, Copy, Debug)]
pub struct Plane {
    n: Vec3,
    /// (n.x, n.y) / |(n.x, n.y)|, or 0 when n is the polar axis.
    azimuth: (f32, f32),
    /// |(n.x, n.y)|: c(φ) = n.x cos φ + n.y sin φ ranges over [−a, a].
    a: f32,
}

/// A column of cells (an azimuth range at some depth) against the plane:
/// c(φ) = n.x cos φ + n.y sin φ over the range, which fixes where the
/// plane crosses each meridian.
#[derive(Clone, Copy, Debug)]
struct Column {
    c_min: f32,
    c_max: f32,
    /// The column's first angle (m·2⁻²³ turn) and width, for the
    /// midpoint rule's azimuths.
    m0: u32,
    width: u32,
    depth: u32,
}

/// c at the midpoint rule's azimuths of a column (the first `count`),
/// computed only for a column holding a straddling cell.
struct AzimuthSamples {
    c: [f32; COARSE_AZIMUTH_SAMPLES],
    count: usize,
}

impl Plane {
    /// The plane with unit normal `n`; directions with n·ω > 0 are above.
    pub fn new(n: Vec3) -> Self {
        let a = (n.x * n.x + n.y * n.y).sqrt();
        let azimuth = if a > 0.0 {
            (n.x / a, n.y / a)
        } else {
            (0.0, 0.0)
        };
        Plane { n, azimuth, a }
    }

    #[inline]
    fn c_at(&self, m: u32) -> f32 {
        let (s, c) = turn_sin_cos(m);
        self.n.x * c + self.n.y * s
    }

    /// True when the azimuth of unit vector d lies strictly inside the arc
    /// from e0 to e1 (counter-clockwise, at most half a turn).
    #[inline]
    fn inside_arc(e0: (f32, f32), e1: (f32, f32), d: (f32, f32)) -> bool {
        e0.0 * d.1 - e0.1 * d.0 > 0.0 && d.0 * e1.1 - d.1 * e1.0 > 0.0
    }

    /// Column `iy` at `depth` (1..=20). c(φ) = a·cos(φ − φ_n) takes its
    /// extremes over the range at its ends or at φ_n or φ_n + π.
    #[inline]
    fn column(&self, depth: u32, iy: u32) -> Column {
        let shift = TURN_BITS - depth;
        let m0 = iy << shift;
        let m1 = (iy + 1) << shift;
        let (s0, cos0) = turn_sin_cos(m0);
        let (s1, cos1) = turn_sin_cos(m1);
        let (e0, e1) = ((cos0, s0), (cos1, s1));
        let c0 = self.n.x * e0.0 + self.n.y * e0.1;
        let c1 = self.n.x * e1.0 + self.n.y * e1.1;
        let d = self.azimuth;
        let mut c_min = c0.min(c1);
        let mut c_max = c0.max(c1);
        if self.a > 0.0 {
            if Self::inside_arc(e0, e1, d) {
                c_max = self.a;
            }
            if Self::inside_arc(e0, e1, (-d.0, -d.1)) {
                c_min = -self.a;
            }
        }
        Column {
            c_min,
            c_max,
            m0,
            width: 1 << shift,
            depth,
        }
    }

    /// The midpoint rule's azimuths of `column`: (2j + 1)/(2·count) of its
    /// width, exact angles since 2·count ≤ 2³ below depth 2 and ≤ 2⁴ at
    /// depths 1–2.
    #[inline]
    fn samples(&self, column: &Column) -> AzimuthSamples {
        let count = if column.depth <= COARSE_DEPTH {
            COARSE_AZIMUTH_SAMPLES
        } else {
            AZIMUTH_SAMPLES
        };
        let half_step = column.width / (2 * count as u32);
        let mut c = [0.0; COARSE_AZIMUTH_SAMPLES];
        for (j, c) in c.iter_mut().take(count).enumerate() {
            *c = self.c_at(column.m0 + (2 * j as u32 + 1) * half_step);
        }
        AzimuthSamples { c, count }
    }

    /// The cos θ at azimuth φ where the plane crosses the meridian, given
    /// c = c(φ): n·ω = n.z·z + √(1−z²)·c vanishes at
    /// z = −sign(n.z)·c/√(n.z² + c²). Above it (n.z > 0) or below it
    /// (n.z < 0) the meridian is above the plane.
    #[inline]
    fn crossing(&self, c: f32) -> f32 {
        let z = c / (self.n.z * self.n.z + c * c).sqrt();
        if self.n.z > 0.0 { -z } else { z }
    }

    /// The length of the meridian segment z ∈ [z0, z1] at c(φ) = c that
    /// lies above the plane.
    #[inline]
    fn length_above(&self, c: f32, z0: f32, z1: f32) -> f32 {
        let dz = z1 - z0;
        if self.n.z > 0.0 {
            (z1 - self.crossing(c)).clamp(0.0, dz)
        } else if self.n.z < 0.0 {
            (self.crossing(c) - z0).clamp(0.0, dz)
        } else if c > 0.0 {
            dz
        } else {
            0.0
        }
    }

    /// Where the cell of `column` spanning cos θ ∈ [z0, z1] lies. Exact up
    /// to rounding: the crossing is monotone in c, so its range over the
    /// cell follows from c's.
    #[inline]
    fn side_in(&self, column: &Column, z0: f32, z1: f32) -> Side {
        let (above, below) = if self.n.z > 0.0 {
            // The crossing falls as c grows; above it is above.
            (
                self.crossing(column.c_min) <= z0,
                self.crossing(column.c_max) >= z1,
            )
        } else if self.n.z < 0.0 {
            // The crossing rises with c; below it is above.
            (
                self.crossing(column.c_min) >= z1,
                self.crossing(column.c_max) <= z0,
            )
        } else {
            (column.c_min >= 0.0, column.c_max <= 0.0)
        };
        match (above, below) {
            (true, _) => Side::Above,
            (false, true) => Side::Below,
            _ => Side::Straddles,
        }
    }

    /// The share of the cell of `column` spanning [z0, z1]: exactly 1 or 0
    /// for a cell wholly on one side, otherwise the midpoint rule over the
    /// azimuths of the exact share of each meridian segment, kept below 1
    /// so that a share of exactly 1 always means "wholly above".
    #[inline]
    fn share_in(
        &self,
        column: &Column,
        samples: &mut Option<AzimuthSamples>,
        z0: f32,
        z1: f32,
    ) -> f32 {
        match self.side_in(column, z0, z1) {
            Side::Above => 1.0,
            Side::Below => 0.0,
            Side::Straddles => {
                let s = samples.get_or_insert_with(|| self.samples(column));
                let sum: f32 = s.c[..s.count]
                    .iter()
                    .map(|&c| self.length_above(c, z0, z1))
                    .sum();
                (sum / (s.count as f32 * (z1 - z0))).clamp(0.0, 1.0f32.next_down())
            }
        }
    }

    /// Where `cell` (depth 1..=20) lies against the plane (for the tests;
    /// the weights classify cells through [`Self::share_in`]).
    #[cfg(test)]
    fn side(&self, cell: Cell) -> Side {
        let (z0, z1) = z_range(cell);
        self.side_in(&self.column(cell.depth, cell.iy), z0, z1)
    }

    /// The share of `cell`'s solid angle (depth 1..=20) above the plane
    /// (the cylindrical map preserves area, so it is the share of the
    /// cell's (z, φ) rectangle). Deterministic in the cell, which is all
    /// sampling and pdf need from it; its accuracy only decides how many
    /// guided samples still fall below.
    pub fn fraction_above(&self, cell: Cell) -> f32 {
        let (z0, z1) = z_range(cell);
        self.share_in(&self.column(cell.depth, cell.iy), &mut None, z0, z1)
    }

    /// The shares of the 4 children of `cell` (depth 0..=19), bit for bit
    /// [`Self::fraction_above`] of each, with the two columns' azimuths
    /// computed once.
    pub fn children_fractions(&self, cell: Cell) -> [f32; 4] {
        let columns = [0, 1].map(|j| self.column(cell.depth + 1, 2 * cell.iy + j));
        let rows = [0, 1].map(|i| {
            z_range(Cell {
                depth: cell.depth + 1,
                ix: 2 * cell.ix + i,
                iy: 0,
            })
        });
        let mut samples = [None, None];
        std::array::from_fn(|k| {
            let (z0, z1) = rows[k & 1];
            self.share_in(&columns[k >> 1], &mut samples[k >> 1], z0, z1)
        })
    }
}

/// A cell's cos θ bounds, exact in f32 for dyadic cells down to depth 20.
#[inline]
fn z_range(cell: Cell) -> (f32, f32) {
    let size = cell.square_size();
    let z0 = 2.0 * (cell.ix as f32 * size) - 1.0;
    (z0, z0 + 2.0 * size)
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::directional::square_to_dir;
    use crate::sampling::Rng;
    use glam::Vec2;

    fn random_normal(rng: &mut Rng) -> Vec3 {
        square_to_dir(rng.next_2d())
    }

    fn random_cell(rng: &mut Rng, depth: u32) -> Cell {
        let n = 1u32 << depth;
        Cell {
            depth,
            ix: rng.next_u32() % n,
            iy: rng.next_u32() % n,
        }
    }

    /// The share of the cell above the plane by stratified sampling.
    fn monte_carlo_share(plane_n: Vec3, cell: Cell, m: usize) -> f64 {
        let (u0, v0, s) = cell.square_bounds();
        let mut above = 0usize;
        for i in 0..m {
            for j in 0..m {
                let p = Vec2::new(
                    (u0 + (i as f64 + 0.5) / m as f64 * s) as f32,
                    (v0 + (j as f64 + 0.5) / m as f64 * s) as f32,
                );
                above += (plane_n.dot(square_to_dir(p)) > 0.0) as usize;
            }
        }
        above as f64 / (m * m) as f64
    }

    /// Cells classified as wholly on one side are, at every one of 4096
    /// points; a cell with points on both sides is never so classified.
    #[test]
    fn the_side_test_is_exact() {
        let mut rng = Rng::new(5, 1);
        let mut counts = [0usize; 3];
        for trial in 0..4000 {
            let n = match trial % 5 {
                0 => Vec3::Z,
                1 => -Vec3::X,
                2 => Vec3::new(0.0, 0.6, -0.8),
                _ => random_normal(&mut rng),
            };
            let cell = random_cell(&mut rng, 1 + trial as u32 % 7);
            let share = monte_carlo_share(n, cell, 64);
            let side = Plane::new(n).side(cell);
            match side {
                Side::Above => assert_eq!(share, 1.0, "{cell:?} n {n}"),
                Side::Below => assert_eq!(share, 0.0, "{cell:?} n {n}"),
                Side::Straddles => {}
            }
            if share > 0.0 && share < 1.0 {
                assert_eq!(side, Side::Straddles, "{cell:?} n {n} share {share}");
            }
            counts[side as usize] += 1;
        }
        assert!(counts.iter().all(|&c| c > 300), "{counts:?}");
    }

    /// The midpoint rule against 256² stratified points, by depth: it
    /// samples 8 azimuths of a cell at depths 1–2 and 4 deeper.
    #[test]
    fn the_share_above_agrees_with_monte_carlo() {
        let mut rng = Rng::new(9, 2);
        for depth in 1..=10u32 {
            // Measured: at most 0.038 at depths 1–2 and 0.116 deeper.
            let tolerance = if depth <= COARSE_DEPTH { 0.05 } else { 0.15 };
            let mut worst = 0.0f64;
            let mut tested = 0;
            while tested < 60 {
                let n = random_normal(&mut rng);
                let cell = random_cell(&mut rng, depth);
                let plane = Plane::new(n);
                if plane.side(cell) != Side::Straddles {
                    // Straddling cells are rare at depth; aim one at the plane.
                    continue;
                }
                let share = plane.fraction_above(cell) as f64;
                worst = worst.max((share - monte_carlo_share(n, cell, 256)).abs());
                tested += 1;
            }
            assert!(worst < tolerance, "depth {depth}: worst error {worst}");
        }
    }

    /// A group of 4 children, with shared azimuths, gives each child's share
    /// bit for bit as computed alone: the memo and the descent rely on it.
    #[test]
    fn children_shares_equal_single_shares_bit_for_bit() {
        let mut rng = Rng::new(12, 5);
        let mut straddling = 0;
        for trial in 0..20_000 {
            let n = random_normal(&mut rng);
            let cell = random_cell(&mut rng, trial as u32 % 20);
            let plane = Plane::new(n);
            let group = plane.children_fractions(cell);
            for (k, g) in group.iter().enumerate() {
                let alone = plane.fraction_above(cell.child(k));
                assert_eq!(g.to_bits(), alone.to_bits(), "{cell:?} child {k} n {n}");
                assert!((0.0..=1.0).contains(g));
                straddling += (*g > 0.0 && *g < 1.0) as usize;
            }
        }
        assert!(straddling > 1000, "only {straddling} straddling children");
    }

    /// The octant-reduced sine and cosine against f64.
    #[test]
    fn turn_sin_cos_is_accurate() {
        let mut worst = 0.0f64;
        for m in (0..1u32 << TURN_BITS)
            .step_by(997)
            .chain([0, 1 << 20, 1 << 21, (1 << 23) - 1])
        {
            let (s, c) = turn_sin_cos(m);
            let a = std::f64::consts::TAU * m as f64 / (1u64 << TURN_BITS) as f64;
            worst = worst
                .max((s as f64 - a.sin()).abs())
                .max((c as f64 - a.cos()).abs());
        }
        assert!(worst < 5e-7, "worst error {worst}");
    }
}
