//! Practical path guiding (Müller et al. 2017, with the 2019 production
//! notes): the guiding data structures and their learning, independent of
//! the renderer.
//!
//! - [`quadtree`]: the directional quadtree as data, and recording into it;
//! - [`build`]: learning the next sampling tree from recorded flux;
//! - [`descent`]: the one descent shared by sampling and pdf, parameterised
//!   by a [`descent::ChildWeights`] (radiance or product);
//! - [`sdtree`]: the spatial binary tree whose leaves own quadtree pairs;
//! - [`record`]: per-thread record buffers and their deterministic merge;
//! - [`adam`]: the learned BSDF-sampling fraction;
//! - [`adrrs`]: adjoint-driven Russian roulette;
//! - [`schedule`]: the training schedule and the inverse-variance
//!   combination of iterations.

pub mod adam;
pub mod adrrs;
pub mod build;
pub mod descent;
pub mod quadtree;
pub mod record;
pub mod schedule;
pub mod sdtree;
