//! ltcguide: practical product path guiding with Linearly Transformed Cosines
//! (Diolatzis, Gruson, Jakob, Nowrouzezahrai and Drettakis, CGF 2020).

// `!(x > 0.0)` is how this crate says "not positive, or NaN": the guards
// that keep NaN out of images, trees and optimizers rely on it.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod bsdf;
pub mod camera;
pub mod cpu_clock;
pub mod directional;
pub mod emitter;
pub mod experiment;
pub mod film;
pub mod guards;
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
