//! ltcguide: practical product path guiding with Linearly Transformed Cosines
//! (Diolatzis, Gruson, Jakob, Nowrouzezahrai and Drettakis, CGF 2020).

pub mod accel;
pub mod bsdf;
pub mod camera;
pub mod directional;
pub mod emitter;
pub mod experiment;
pub mod film;
pub mod guiding;
pub mod huge;
pub mod integrator;
pub mod ltc;
pub mod math;
pub mod pacing;
pub mod plan;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod stats;
pub mod texture;
