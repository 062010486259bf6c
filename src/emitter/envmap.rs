//! Mitsuba's lat-long `envmap` emitter: bilinear radiance lookups and
//! importance sampling of a piecewise-constant bound on them.

use crate::math::{PI, Spectrum, luminance};
use crate::sampling::Distribution1D;
use crate::texture::RgbImage;
use glam::{Mat3, Vec2, Vec3};

/// Mitsuba's lat-long environment map (scene pack README, "envmap").
#[derive(Clone, Debug)]
pub struct EnvMap {
    pub image: RgbImage,
    pub scale: f32,
    to_local: Mat3,
    to_world: Mat3,
    rows: Distribution1D,
    row_cdfs: Vec<Distribution1D>,
}

impl EnvMap {
    pub fn new(image: RgbImage, scale: f32, to_world: Mat3) -> Self {
        let (w, h) = (image.width, image.height);
        // Piecewise-constant sampling over a W×H grid in (u, v). Each cell's
        // weight bounds the bilinear lookup over the cell from above (max of
        // the pixels it can touch), so every direction with non-zero radiance
        // has non-zero pdf.
        let mut row_cdfs = Vec::with_capacity(h);
        let mut row_weights = Vec::with_capacity(h);
        for j in 0..h {
            let y_lo = ((j as f32 / h as f32) * (h as f32 - 1.0)).floor() as usize;
            let y_hi = (((j + 1) as f32 / h as f32) * (h as f32 - 1.0)).ceil() as usize;
            let theta0 = PI * j as f32 / h as f32;
            let theta1 = PI * (j + 1) as f32 / h as f32;
            let max_sin = if theta0 <= 0.5 * PI && theta1 >= 0.5 * PI {
                1.0
            } else {
                theta0.sin().max(theta1.sin())
            };
            let mut weights = Vec::with_capacity(w);
            for i in 0..w {
                let mut m = 0.0f32;
                for y in y_lo..=y_hi.min(h - 1) {
                    for dx in [w - 1, 0, 1] {
                        let x = (i + dx) % w;
                        let v = luminance(image.get(x, y));
                        if v.is_finite() {
                            m = m.max(v);
                        }
                    }
                }
                weights.push(m * max_sin);
            }
            let d = Distribution1D::new(&weights);
            row_weights.push(d.integral as f32);
            row_cdfs.push(d);
        }
        EnvMap {
            rows: Distribution1D::new(&row_weights),
            row_cdfs,
            image,
            scale,
            to_local: to_world.inverse(),
            to_world,
        }
    }

    fn direction_to_uv(&self, d: Vec3) -> Vec2 {
        let l = self.to_local * d;
        let mut u = l.x.atan2(-l.z) / (2.0 * PI);
        if u < 0.0 {
            u += 1.0;
        }
        let v = l.y.clamp(-1.0, 1.0).acos() / PI;
        Vec2::new(u.min(1.0), v)
    }

    pub fn eval(&self, d: Vec3) -> Spectrum {
        let uv = self.direction_to_uv(d);
        let (w, h) = (self.image.width, self.image.height);
        let x = uv.x * w as f32 - 0.5;
        let y = (uv.y * (h as f32 - 1.0)).clamp(0.0, h as f32 - 1.0);
        let (fx, fy) = (x.floor(), y.floor());
        let (tx, ty) = (x - fx, y - fy);
        let x0 = (fx as i64).rem_euclid(w as i64) as usize;
        let x1 = (x0 + 1) % w;
        let y0 = fy as usize;
        let y1 = (y0 + 1).min(h - 1);
        let top = self.image.get(x0, y0) * (1.0 - tx) + self.image.get(x1, y0) * tx;
        let bot = self.image.get(x0, y1) * (1.0 - tx) + self.image.get(x1, y1) * tx;
        let v = (top * (1.0 - ty) + bot * ty) * self.scale;
        if crate::math::is_finite3(v) {
            v.max(Spectrum::ZERO)
        } else {
            Spectrum::ZERO
        }
    }

    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let (j, pj, uy) = self.rows.sample_discrete(u.y);
        let (i, pi, ux) = self.row_cdfs[j].sample_discrete(u.x);
        let (w, h) = (self.image.width as f32, self.image.height as f32);
        let uv = Vec2::new((i as f32 + ux) / w, (j as f32 + uy) / h);
        let pdf_uv = pj * pi * w * h;
        let theta = uv.y * PI;
        let phi = uv.x * 2.0 * PI;
        let sin_t = theta.sin();
        if sin_t <= 0.0 || pdf_uv <= 0.0 {
            return None;
        }
        let local = Vec3::new(sin_t * phi.sin(), theta.cos(), -sin_t * phi.cos());
        let d = (self.to_world * local).normalize();
        Some((d, pdf_uv / (2.0 * PI * PI * sin_t)))
    }

    pub fn pdf(&self, d: Vec3) -> f32 {
        let uv = self.direction_to_uv(d);
        let (w, h) = (self.image.width, self.image.height);
        let i = ((uv.x * w as f32) as usize).min(w - 1);
        let j = ((uv.y * h as f32) as usize).min(h - 1);
        let pdf_uv = self.rows.discrete_pdf(j) * self.row_cdfs[j].discrete_pdf(i) * (w * h) as f32;
        let sin_t = (uv.y * PI).sin();
        if sin_t <= 0.0 {
            return 0.0;
        }
        pdf_uv / (2.0 * PI * PI * sin_t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use crate::sampling::square_to_uniform_sphere;

    #[test]
    fn envmap_sampling_matches_its_pdf_and_integrates_radiance() {
        let env = spot_and_band();
        let mut rng = Rng::new(9, 0);
        let mut est_is = 0.0f64;
        let mut est_uniform = 0.0f64;
        let mut mismatches = 0u32;
        let n = 200_000;
        for _ in 0..n {
            if let Some((d, pdf)) = env.sample(rng.next_2d()) {
                // A direction within rounding of a cell boundary can map
                // back to the neighbouring cell; that must stay rare.
                if (env.pdf(d) - pdf).abs() > 1e-3 * pdf {
                    mismatches += 1;
                }
                est_is += (luminance(env.eval(d)) / pdf) as f64;
            }
            let d = square_to_uniform_sphere(rng.next_2d());
            est_uniform += (luminance(env.eval(d)) * 4.0 * PI) as f64;
        }
        assert!(mismatches < n / 1000, "{mismatches} pdf mismatches");
        let (a, b) = (est_is / n as f64, est_uniform / n as f64);
        assert!((a - b).abs() < 0.02 * b, "importance {a} vs uniform {b}");
    }

    /// A small map with a bright spot, a dark band and a gradient.
    fn spot_and_band() -> EnvMap {
        let (w, h) = (16, 8);
        let pixels = (0..w * h)
            .map(|k| match (k % w, k / w) {
                (3, 2) => Spectrum::splat(50.0),
                (_, 6) => Spectrum::ZERO,
                (x, _) => Spectrum::splat(1.0 + 0.1 * x as f32),
            })
            .collect();
        EnvMap::new(
            RgbImage {
                width: w,
                height: h,
                pixels,
            },
            1.0,
            Mat3::from_rotation_y(0.3),
        )
    }

    /// χ² of the samples against the pdf, twice: in the map's (u, v), with
    /// bins aligned to its pixels, so the expected counts are exact and the
    /// row and column choice is tested alone; and on the sphere, where the
    /// density per solid angle (the 2π² sin θ Jacobian) is tested too.
    #[test]
    fn envmap_sampling_passes_chi2() {
        use crate::stats::chi2::{Chi2Config, SphereMap, chi2_sphere, chi2_square};
        let env = spot_and_band();
        let cfg = Chi2Config {
            res_x: 32,
            res_y: 16,
            samples: 400_000,
            ..Default::default()
        };
        let mut rng = Rng::new(3, 0);
        let uv_to_dir = |uv: glam::DVec2| {
            let (theta, phi) = (
                uv.y * std::f64::consts::PI,
                uv.x * 2.0 * std::f64::consts::PI,
            );
            let local = Vec3::new(
                (theta.sin() * phi.sin()) as f32,
                theta.cos() as f32,
                (-theta.sin() * phi.cos()) as f32,
            );
            (env.to_world * local, theta.sin())
        };
        let on_map = chi2_square(
            &cfg,
            || {
                env.sample(rng.next_2d())
                    .map(|(d, _)| env.direction_to_uv(d))
            },
            |uv| {
                let (d, sin_t) = uv_to_dir(uv);
                env.pdf(d) as f64 * 2.0 * std::f64::consts::PI.powi(2) * sin_t
            },
        );
        assert!(on_map.passed, "(u, v): {}", on_map.message);
        assert!(
            (on_map.pdf_integral - 1.0).abs() < 1e-3,
            "{}",
            on_map.message
        );
        let on_sphere = chi2_sphere(
            &cfg,
            &SphereMap::new(Vec3::Y, 1.0),
            || env.sample(rng.next_2d()).map(|(d, _)| d),
            |d| env.pdf(d) as f64,
        );
        assert!(on_sphere.passed, "sphere: {}", on_sphere.message);
        assert!(
            (on_sphere.pdf_integral - 1.0).abs() < 2e-3,
            "{}",
            on_sphere.message
        );
    }
}
