//! Mesh lights made of two triangles forming a parallelogram (`rectangle`
//! shapes, the common area light) are sampled as one parallelogram: a point
//! uniform in area is o + s·u + t·v for (s, t) uniform in the square, as
//! Mitsuba samples a rectangle. Picking a triangle and warping into it costs
//! a CDF search and a square root on the shadow-ray path.

use super::EmitterTriangle;
use glam::{Vec2, Vec3};

#[derive(Clone, Copy, Debug)]
pub struct Parallelogram {
    o: Vec3,
    u: Vec3,
    v: Vec3,
}

impl Parallelogram {
    /// Recognises two triangles sharing a diagonal whose opposite corners
    /// complete a parallelogram; triangles with shading normals are left to
    /// the per-triangle path, which interpolates them.
    pub fn detect(triangles: &[EmitterTriangle]) -> Option<Self> {
        let [a, b] = triangles else {
            return None;
        };
        if a.n.is_some() || b.n.is_some() {
            return None;
        }
        let pa = [a.p0, a.p0 + a.e1, a.p0 + a.e2];
        let pb = [b.p0, b.p0 + b.e1, b.p0 + b.e2];
        // The corner of `a` not shared with `b` (exactly one must exist).
        let opposite = |p: &[Vec3; 3], q: &[Vec3; 3]| {
            let lone: Vec<usize> = (0..3).filter(|&i| !q.contains(&p[i])).collect();
            (lone.len() == 1).then(|| lone[0])
        };
        let ia = opposite(&pa, &pb)?;
        let ib = opposite(&pb, &pa)?;
        let o = pa[ia];
        let d1 = pa[(ia + 1) % 3];
        let d2 = pa[(ia + 2) % 3];
        let (u, v) = (d1 - o, d2 - o);
        // The far corner must be o + u + v up to rounding (and the
        // parallelogram non-degenerate: `Light::mesh` checked the area).
        let scale = u.length() + v.length();
        if (o + u + v - pb[ib]).length() > 1e-5 * scale || !scale.is_finite() {
            return None;
        }
        Some(Parallelogram { o, u, v })
    }

    /// A point uniform in area and the index of the triangle it lies in:
    /// the first triangle is (o, o + u, o + v), the half s + t ≤ 1.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, usize) {
        let q = self.o + self.u * u.x + self.v * u.y;
        (q, (u.x + u.y > 1.0) as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(p: [Vec3; 3]) -> EmitterTriangle {
        EmitterTriangle {
            prim: 0,
            p0: p[0],
            e1: p[1] - p[0],
            e2: p[2] - p[0],
            n: None,
        }
    }

    #[test]
    fn detects_rectangles_and_samples_inside_the_right_triangle() {
        let c = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(2.0, 0.0, 1.0),
            Vec3::new(2.0, 3.0, 1.5),
            Vec3::new(0.0, 3.0, 1.5),
        ];
        let tris = [tri([c[0], c[1], c[2]]), tri([c[0], c[2], c[3]])];
        let p = Parallelogram::detect(&tris).expect("a rectangle");
        let mut rng = crate::sampling::Rng::new(5, 0);
        for _ in 0..1000 {
            let (q, i) = p.sample(rng.next_2d());
            // Barycentrics of q in the reported triangle lie in [0, 1].
            let t = &tris[i];
            let n = t.e1.cross(t.e2);
            let w = q - t.p0;
            let b1 = w.cross(t.e2).dot(n) / n.length_squared();
            let b2 = t.e1.cross(w).dot(n) / n.length_squared();
            let eps = 1e-5;
            assert!(
                b1 >= -eps && b2 >= -eps && b1 + b2 <= 1.0 + eps,
                "{b1} {b2}"
            );
        }
        // Not a parallelogram: the fourth corner moved.
        let skew = [tri([c[0], c[1], c[2]]), tri([c[0], c[2], c[3] + Vec3::X])];
        assert!(Parallelogram::detect(&skew).is_none());
        assert!(Parallelogram::detect(&tris[..1]).is_none());
    }
}
