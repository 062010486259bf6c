//! Practical path guiding (Müller et al. 2017, with the 2019 production
//! notes): the guiding data structures and their learning, independent of
//! the renderer.
//!
//! - [`quadtree`]: the directional quadtree as data, and recording into it;
//! - [`build`]: learning the next sampling tree from recorded flux;
//! - [`descent`]: the one descent shared by sampling and pdf, parameterised
//!   by a [`descent::ChildWeights`] (radiance or product);
//! - [`defensive`]: the product's guided samples mixed with a share drawn
//!   from the radiance descent of the same tree;
//! - [`share_learning`]: that share learned per spatial leaf (optional);
//! - [`sdtree`]: the spatial binary tree whose leaves own quadtree pairs;
//! - [`record`]: per-thread record buffers and their deterministic merge;
//! - [`adam`]: the learned BSDF-sampling fraction;
//! - [`moment_grid`]: a fraction chosen from a grid by the estimator's
//!   second moment, for α or the share (optional);
//! - [`adrrs`]: adjoint-driven Russian roulette;
//! - [`schedule`]: the training schedule;
//! - [`combine`]: the inverse-variance combination of iterations;
//! - [`support`]: radiance weights restricted to a reflecting surface's
//!   hemisphere, with [`plane_share`], the share of a cell above a plane;
//! - [`trial`]: the plan's measured choice between the guide's weights and
//!   path tracing;
//! - [`projection`]: what a fallback to path tracing would cost the run;
//! - [`fallback_image`]: what a run that falls back to path tracing images.
//!
//! Integration, per render:
//! ```text
//! let mut tree = SdTree::new(scene_min, scene_max, SdTreeConfig::default());
//! let mut schedule = Schedule::new(Budget::Spp(n));
//! loop { match schedule.next() {
//!   Step::Done => break,
//!   step @ (Step::Train { .. } | Step::Final { .. }) => {
//!     // each thread, at each non-delta vertex x with outgoing ω_o:
//!     let id = tree.lookup(x); let leaf = tree.leaf(id);
//!     let alpha = tree.bsdf_fraction(id);          // α ∈ [α_min, 1]
//!     // sample: with prob. α the BSDF, else
//!     //   defensive::sample_direction(&leaf.sampling, &mut weights, β, u)
//!     //   (β = 0, or radiance weights: descent::sample_direction)
//!     //   (None ⇒ guide unavailable: use α = 1, record guided = false)
//!     // p_mix = α·p_bsdf + (1−α)·defensive::pdf_direction(&leaf.sampling, &mut weights, β, ω_i)
//!     // after the path: buffer.push(Record { radiance: L_i/p_mix, .. })
//!     // after the pass (training only):
//!     //   record_pass(&mut tree, &buffers);
//!     // after the iteration: tree.refine(k); schedule.report(step, report);
//!   } } }
//! // final image: combine::combine, all iterations weighted by inverse variance
//! // (after a fallback to path tracing: its passes alone, fallback_image).
//! ```

pub mod adam;
pub mod adrrs;
pub mod aov;
pub mod build;
pub mod combine;
pub mod defensive;
pub mod descent;
pub mod fallback_image;
pub mod guide;
pub mod moment_grid;
pub mod pixel_reuse;
pub mod plane_share;
pub mod product;
pub mod projection;
pub mod quadtree;
pub mod record;
pub mod schedule;
pub mod sdtree;
pub mod share_learning;
pub mod support;
pub mod train;
pub mod trial;
