//! Every pack scene renders and agrees with its Mitsuba 3 reference within a
//! statistical tolerance.
//!
//! Tolerance: the image is cut into 32×32 blocks; each block mean is the
//! mean of 1024·spp path samples, and its standard error is estimated from
//! the per-pixel sample variances (ours, plus the reference's, estimated
//! from ours scaled by the sample-count ratio: the reference is the same
//! estimator with more samples). If the renderers agree, block z-scores are
//! ≈ N(0, 1), so E[z²] = 1. We require mean z² < 2 (a systematic bias of
//! one standard error in every block would already give 2), at most 3 % of
//! the blocks beyond |z| = 4 (0.006 % for a normal), and the whole-image mean
//! within 4 standard errors.
//!
//! Why not a bound on the largest |z|: paths that are rare at 16 spp but
//! carry much energy (caustics from the glossy plates of veach-mis onto the
//! walls, which still sparkle in Mitsuba's reference) make a block's sample
//! variance underestimate its true variance whenever the block saw none of
//! them, so one or two such blocks reach |z| ≈ 6–9 with a correct renderer.
//! A wrong BSDF, a flipped normal, a missing light or a 1 % bias in direct
//! lighting (a bug this test caught: mean z² = 140 on veach-mis) shifts
//! dozens of blocks by many σ and fails every criterion above.

mod common;

use common::*;
use ltcguide::render::Method;

fn check(name: &str, spp: u32) {
    let Some((scene, dir)) = pack_scene(name) else {
        return;
    };
    let (reference, ref_spp) = reference(&dir);
    let result = render_spp(&scene, Method::Pt, spp, 7, true);
    assert_eq!(
        result.stats.counters.nonfinite_samples, 0,
        "{name}: non-finite samples"
    );
    let cmp = compare_with_reference(&result, &reference, ref_spp, 32);
    assert_blocks_agree(&format!("{name} vs reference"), &cmp);
}

#[test]
fn cornell_box_matches_reference() {
    check("cornell-box", 16);
}

#[test]
fn veach_mis_matches_reference() {
    check("veach-mis", 16);
}

#[test]
fn veach_ajar_matches_reference() {
    check("veach-ajar", 16);
}

#[test]
fn staircase_matches_reference() {
    check("staircase", 16);
}

#[test]
fn living_room_matches_reference() {
    check("living-room", 16);
}
