//! ltcguide: practical product path guiding with Linearly Transformed Cosines
//! (Diolatzis, Gruson, Jakob, Nowrouzezahrai and Drettakis, CGF 2020).

pub mod bsdf;
pub mod directional;
pub mod film;
pub mod ltc;
pub mod math;
pub mod sampling;
pub mod stats;
pub mod texture;
