//! Materials and directions shared by the BSDF tests.
#![allow(dead_code)]

use glam::{Vec2, Vec3};
use ltcguide::bsdf::{Bsdf, ConductorFresnel, Material, MaterialKind};
use ltcguide::math::Spectrum;
use ltcguide::texture::Texture;

pub const ALPHAS: [f32; 4] = [0.01, 0.1, 0.5, 1.0];
pub const THETAS_DEG: [f32; 5] = [0.0, 30.0, 60.0, 85.0, 89.0];

pub fn c(v: f32) -> Texture {
    Texture::Constant(Spectrum::splat(v))
}

pub fn diffuse(rho: f32, two_sided: bool) -> Bsdf {
    Material::new(
        MaterialKind::Diffuse {
            reflectance: c(rho),
        },
        two_sided,
    )
    .unwrap()
    .at(Vec2::ZERO)
}

pub fn gold() -> ConductorFresnel {
    ConductorFresnel::Complex {
        eta: Spectrum::new(0.1431, 0.3749, 1.4425),
        k: Spectrum::new(3.9831, 2.3857, 1.6032),
    }
}

pub fn rough_conductor(alpha: f32, fresnel: ConductorFresnel, two_sided: bool) -> Bsdf {
    Material::new(
        MaterialKind::RoughConductor {
            alpha,
            fresnel,
            specular_reflectance: c(1.0),
        },
        two_sided,
    )
    .unwrap()
    .at(Vec2::ZERO)
}

pub fn rough_plastic(alpha: f32, rho: f32, two_sided: bool) -> Bsdf {
    Material::new(
        MaterialKind::RoughPlastic {
            alpha,
            eta: 1.5,
            diffuse_reflectance: c(rho),
        },
        two_sided,
    )
    .unwrap()
    .at(Vec2::ZERO)
}

pub fn plastic(rho: f32) -> Bsdf {
    Material::new(
        MaterialKind::Plastic {
            eta: 1.5,
            diffuse_reflectance: c(rho),
        },
        false,
    )
    .unwrap()
    .at(Vec2::ZERO)
}

pub fn wo_at(theta_deg: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

pub fn flip(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}
