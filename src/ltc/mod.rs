//! Linearly transformed cosines for product guiding.
pub mod children;
pub mod children_x16;
pub mod fit;
pub mod form_factor;
pub mod ggx;
pub mod lobe;
pub mod polygon;
pub mod sphere_clip;
pub mod table;
