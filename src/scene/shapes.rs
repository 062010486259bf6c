//! Analytic shapes of the subset turned into primitives: `rectangle` and
//! `cube` become triangles with per-vertex uv, `sphere` stays analytic.

use glam::{Mat3, Mat4, Vec2, Vec3};

/// A triangle with everything shading needs.
#[derive(Clone, Copy, Debug)]
pub struct ShapeTriangle {
    pub p: [Vec3; 3],
    /// Shading normals, or `None` for flat shading.
    pub n: Option<[Vec3; 3]>,
    pub uv: [Vec2; 3],
}

/// The first triangle with zero area in f32: the light sampler drops such
/// triangles, so an emitter made of them would vanish without a word.
pub fn first_degenerate(tris: &[ShapeTriangle]) -> Option<usize> {
    tris.iter()
        .position(|t| (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).length_squared() == 0.0)
}

/// Applies `to_world` to a local triangle whose intended normal is `local_n`,
/// keeping the winding consistent with the transformed normal (a mirroring
/// transform would otherwise turn the triangle's geometric normal around).
fn transformed_triangle(
    m: &Mat4,
    normal_m: &Mat3,
    p: [Vec3; 3],
    uv: [Vec2; 3],
    local_n: Vec3,
) -> ShapeTriangle {
    let mut pw = p.map(|q| m.transform_point3(q));
    let mut uvw = uv;
    let n = (*normal_m * local_n).normalize_or_zero();
    if (pw[1] - pw[0]).cross(pw[2] - pw[0]).dot(n) < 0.0 {
        pw.swap(1, 2);
        uvw.swap(1, 2);
    }
    ShapeTriangle {
        p: pw,
        n: None,
        uv: uvw,
    }
}

fn normal_matrix(m: &Mat4) -> Mat3 {
    Mat3::from_mat4(*m).inverse().transpose()
}

/// The square [−1, 1]² × {0}, normal +z, uv = ((x+1)/2, (y+1)/2).
pub fn rectangle(m: &Mat4) -> Vec<ShapeTriangle> {
    let nm = normal_matrix(m);
    let c = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    let uv = c.map(|p| Vec2::new((p.x + 1.0) * 0.5, (p.y + 1.0) * 0.5));
    vec![
        transformed_triangle(m, &nm, [c[0], c[1], c[2]], [uv[0], uv[1], uv[2]], Vec3::Z),
        transformed_triangle(m, &nm, [c[0], c[2], c[3]], [uv[0], uv[2], uv[3]], Vec3::Z),
    ]
}

/// The cube [−1, 1]³ as 12 triangles with outward flat normals.
pub fn cube(m: &Mat4) -> Vec<ShapeTriangle> {
    let nm = normal_matrix(m);
    let mut out = Vec::with_capacity(12);
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            // Two tangent axes spanning the face.
            let a = (axis + 1) % 3;
            let b = (axis + 2) % 3;
            let corner = |s: f32, t: f32| {
                let mut p = n;
                p[a] = s;
                p[b] = t;
                p
            };
            let c = [
                corner(-1.0, -1.0),
                corner(1.0, -1.0),
                corner(1.0, 1.0),
                corner(-1.0, 1.0),
            ];
            let uv = [
                Vec2::new(0.0, 0.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(1.0, 1.0),
                Vec2::new(0.0, 1.0),
            ];
            out.push(transformed_triangle(
                m,
                &nm,
                [c[0], c[1], c[2]],
                [uv[0], uv[1], uv[2]],
                n,
            ));
            out.push(transformed_triangle(
                m,
                &nm,
                [c[0], c[2], c[3]],
                [uv[0], uv[2], uv[3]],
                n,
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangle_and_cube_normals_follow_the_transform() {
        let m = Mat4::from_scale(Vec3::new(-2.0, 1.0, 1.0)); // mirroring
        for t in rectangle(&m) {
            let n = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).normalize();
            assert!((n - Vec3::Z).length() < 1e-6);
        }
        let tris = cube(&Mat4::IDENTITY);
        assert_eq!(tris.len(), 12);
        for t in tris {
            let n = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).normalize();
            let centre = (t.p[0] + t.p[1] + t.p[2]) / 3.0;
            assert!(n.dot(centre) > 0.0, "cube normals point outwards");
        }
    }
}
