//! A defensive radiance share for product guiding: the guided sample comes
//! from the product descent with probability 1 − β and from the radiance
//! descent of the same quadtree with probability β, and its pdf is the
//! mixture (1 − β)·p_product + β·p_radiance (one-sample MIS with the
//! balance heuristic, as the BSDF fraction mixes the BSDF in).
//!
//! Why the product needs it. The tree's radiance is an average over a
//! spatial leaf and a directional cell: a light smaller than that blur
//! (veach-mis's spheres seen from its plates) lies somewhere inside the
//! cells that hold it, at a place that moves from shading point to shading
//! point. Inside that footprint radiance guiding spreads its samples by
//! area, while the product spreads them by the BSDF. A light of solid angle
//! |S| at a place where the lobe is D(S) is then hit with probability
//! ∝ D(S)/D̄ times radiance guiding's (D̄ the lobe's mean over the
//! footprint), and the variance goes as its inverse: averaged over where
//! the light falls, D̄·mean(1/D) ≥ 1 (Jensen), large for a lobe narrower
//! than the footprint. The BSDF fraction cannot cover it either, since the
//! BSDF concentrates where the product does. A share β of radiance samples
//! bounds the loss: the mixture's pdf is at least β times radiance
//! guiding's everywhere.
//!
//! Sample and pdf run the same two descents, so the pdf of a sampled
//! direction is the returned pdf bit for bit. With β = 0, or weights that
//! are the radiance already, both are the plain descent.

use super::descent::{self, ChildWeights, ONE_MINUS_EPS, RadianceWeights};
use super::quadtree::QuadTree;
use crate::directional::{SQUARE_TO_SOLID_ANGLE_PDF, dir_to_square, square_to_dir};
use glam::{Vec2, Vec3};

/// Product guiding's default radiance share β.
///
/// Measured in the paper's setting (no NEE, ADRRS) on an Intel AVX-512
/// host, product/radiance relative variance per sample of the final
/// iteration at 64 spp, 3 seeds (`attribute SCENE --spp 64 --seeds 3`;
/// docs/results-reading.md, session 52), β = 0 → 0.3, over the image and
/// at the glossy first vertices, where the product acts:
///
/// | scene | image | glossy first vertices |
/// |---|---|---|
/// | staircase | 1.041 → 0.982 | 1.066 → 0.980 |
/// | veach-mis | 1.088 → 1.040 | 1.323 → 1.118 (β = 0.5: 1.119) |
/// | veach-ajar | 1.020 → 1.055 | 1.039 → 1.088 |
/// | living-room | 0.919 → 0.902 | 0.878 → 0.859 |
///
/// Its cost did not show (16 spp side by side, staircase and veach-mis,
/// 2 seeds: CPU × 0.94–1.03, mean 0.99). At 120 CPU s, 4 seeds, the
/// product's staircase relMSE fell from 0.054 to 0.039 (radiance
/// guiding's: 0.033 and 0.035), its worst seed from 2.4× radiance
/// guiding's to 1.2×. veach-ajar's loss is its seeds' spread: over 6
/// seeds its relative variance per sample went 1.077 → 1.033.
pub const DEFAULT_RADIANCE_SHARE: f32 = 0.3;

/// Whether product guiding learns its radiance share per spatial leaf by
/// default (`super::share_learning`).
///
/// Off: no learner beat the fixed share on every glossy scene. Product /
/// radiance relative variance per sample of the final iteration at 64 spp,
/// 3 seeds, the paper's setting (docs/results-reading.md, session 53),
/// fixed 0.3 against learned per leaf from 0.3 by Adam on the KL, Adam on
/// the variance, and the variance grid:
///
/// | scene | fixed | KL | variance | grid |
/// |---|---|---|---|---|
/// | staircase | 0.967 | 0.928 | 0.895 | 0.935 |
/// | veach-mis | 1.090 | 1.111 | 1.107 | 1.066 |
/// | veach-ajar | 1.041 | | 1.001 | 1.079 |
/// | living-room | 0.899 | | 0.913 | 0.911 |
///
/// Every learner took most leaves' share below 0.3 (weighted means 0.06–0.23
/// on staircase and veach-mis), which helped staircase and cost veach-mis
/// at its glossy first vertices (1.15 → 1.24–1.31), where the share's
/// rare light-finding samples are what a leaf's own samples under-count.
pub const DEFAULT_SHARE_LEARNING: bool = false;

/// Product guiding's radiance share setting: a fixed β, or β learned per
/// leaf starting from it. A β of 0 is the paper's product alone and
/// learns nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadianceShare {
    pub value: f32,
    pub learned: bool,
    /// What a learned share minimises.
    pub learning: super::share_learning::ShareLearning,
}

impl Default for RadianceShare {
    fn default() -> Self {
        RadianceShare {
            value: DEFAULT_RADIANCE_SHARE,
            learned: DEFAULT_SHARE_LEARNING,
            learning: Default::default(),
        }
    }
}

/// "0.3", or "0.3, learned per leaf", for reports.
impl std::fmt::Display for RadianceShare {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.learned_start() {
            Some(start) => write!(f, "{start}, learned per leaf ({:?})", self.learning),
            None => write!(f, "{}", self.value),
        }
    }
}

impl RadianceShare {
    /// A fixed share β (0: none).
    pub fn fixed(value: f32) -> Self {
        RadianceShare {
            value,
            learned: false,
            learning: Default::default(),
        }
    }

    /// The starting share of a per-leaf learned one, if any.
    pub fn learned_start(&self) -> Option<f32> {
        (self.learned && self.value > 0.0).then_some(self.value)
    }

    pub fn check(&self) -> Result<(), String> {
        check_radiance_share(self.value)
    }

    /// For plan lines and reports.
    pub fn describe(&self) -> String {
        match (self.value > 0.0, self.learned) {
            (false, _) => "product samples alone".into(),
            (true, false) => format!(
                "{} of their guided samples from radiance weights",
                self.value
            ),
            (true, true) => format!(
                "a share of their guided samples from radiance weights learned per leaf from {} ({:?})",
                self.value, self.learning
            ),
        }
    }
}

/// Checks a radiance share given on the command line or in options.
pub fn check_radiance_share(share: f32) -> Result<(), String> {
    if (0.0..1.0).contains(&share) {
        Ok(())
    } else {
        Err(format!(
            "--radiance-share must be in [0, 1) (1 would be radiance guiding: --method radiance), got {share}"
        ))
    }
}

/// True when the guide draws a share of its samples from the radiance:
/// only under product weights (radiance weights are that descent already).
#[inline]
pub(crate) fn mixes<W: ChildWeights>(weights: &W, share: f32) -> bool {
    share > 0.0 && !weights.is_radiance()
}

/// Samples a point of the square and its square-measure mixture pdf. The
/// sample's u.x picks the descent and is stretched back to [0, 1), so a
/// stratified sample stays stratified within each.
pub fn sample<W: ChildWeights>(
    tree: &QuadTree,
    weights: &mut W,
    share: f32,
    u: Vec2,
) -> Option<(Vec2, f32)> {
    if !mixes(weights, share) {
        return descent::sample(tree, weights, u);
    }
    let stretch = |x: f32| x.clamp(0.0, ONE_MINUS_EPS);
    if u.x < share {
        let (p, radiance_pdf) = descent::sample(
            tree,
            &mut RadianceWeights,
            Vec2::new(stretch(u.x / share), u.y),
        )?;
        let product_pdf = descent::pdf(tree, weights, p);
        Some((p, mix(share, product_pdf, radiance_pdf)))
    } else {
        let v = Vec2::new(stretch((u.x - share) / (1.0 - share)), u.y);
        let (p, product_pdf) = descent::sample(tree, weights, v)?;
        let radiance_pdf = descent::pdf(tree, &mut RadianceWeights, p);
        Some((p, mix(share, product_pdf, radiance_pdf)))
    }
}

/// Square-measure mixture pdf of the point `p`.
pub fn pdf<W: ChildWeights>(tree: &QuadTree, weights: &mut W, share: f32, p: Vec2) -> f32 {
    if !mixes(weights, share) {
        return descent::pdf(tree, weights, p);
    }
    let product_pdf = descent::pdf(tree, weights, p);
    let radiance_pdf = descent::pdf(tree, &mut RadianceWeights, p);
    mix(share, product_pdf, radiance_pdf)
}

/// One expression for sample and pdf, so that both round alike.
#[inline]
fn mix(share: f32, product_pdf: f32, radiance_pdf: f32) -> f32 {
    (1.0 - share) * product_pdf + share * radiance_pdf
}

/// Samples a world direction; returns it with its solid-angle pdf.
#[inline]
pub fn sample_direction<W: ChildWeights>(
    tree: &QuadTree,
    weights: &mut W,
    share: f32,
    u: Vec2,
) -> Option<(Vec3, f32)> {
    sample(tree, weights, share, u)
        .map(|(p, pdf)| (square_to_dir(p), pdf * SQUARE_TO_SOLID_ANGLE_PDF))
}

/// Solid-angle pdf of a unit world direction.
#[inline]
pub fn pdf_direction<W: ChildWeights>(
    tree: &QuadTree,
    weights: &mut W,
    share: f32,
    d: Vec3,
) -> f32 {
    pdf(tree, weights, share, dir_to_square(d)) * SQUARE_TO_SOLID_ANGLE_PDF
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::directional::Cell;
    use crate::guiding::quadtree::QuadNode;

    /// Weights that favour child 0 of every node 9:1 over the radiance.
    struct Tilted;
    impl ChildWeights for Tilted {
        fn child_weights(&mut self, _: Cell, r: [f32; 4]) -> [f32; 4] {
            [9.0 * r[0], r[1], r[2], r[3]]
        }
    }

    fn tree() -> QuadTree {
        QuadTree::from_nodes(vec![
            QuadNode {
                sums: [1.0, 2.0, 0.0, 1.0],
                children: [1, 0, 0, 0],
            },
            QuadNode {
                sums: [0.5, 0.1, 0.3, 0.1],
                children: [0; 4],
            },
        ])
        .unwrap()
    }

    /// The mixture's pdf is (1 − β)·product + β·radiance at every point,
    /// it is what sampling returns bit for bit, and β = 0 is the product.
    #[test]
    fn the_pdf_is_the_mixture_and_sampling_returns_it() {
        let t = tree();
        let share = 0.3;
        for i in 0..400 {
            let u = Vec2::new((i as f32 + 0.5) / 400.0, ((i * 37) % 400) as f32 / 400.0);
            let (p, d) = sample(&t, &mut Tilted, share, u).unwrap();
            assert_eq!(pdf(&t, &mut Tilted, share, p), d);
            let product = descent::pdf(&t, &mut Tilted, p);
            let radiance = descent::pdf(&t, &mut RadianceWeights, p);
            assert!((d - (0.7 * product + 0.3 * radiance)).abs() <= 1e-6 * d);
            assert!(d >= share * radiance * (1.0 - 1e-6));
            assert_eq!(
                sample(&t, &mut Tilted, 0.0, u),
                descent::sample(&t, &mut Tilted, u)
            );
        }
        // Radiance weights ignore the share: they are that descent.
        let u = Vec2::new(0.1, 0.9);
        assert_eq!(
            sample(&t, &mut RadianceWeights, share, u),
            descent::sample(&t, &mut RadianceWeights, u)
        );
    }

    /// The samples split between the descents in proportion to β: the
    /// root's child 0 gets 9/12 of the product's samples and 1/4 of the
    /// radiance's.
    #[test]
    fn the_share_splits_the_samples_between_the_descents() {
        let t = tree();
        let n = 20_000;
        let share = 0.25;
        let in_child_0 = |p: Vec2| p.x < 0.5 && p.y < 0.5;
        let mut hits = 0;
        for i in 0..n {
            let u = Vec2::new(
                (i as f32 + 0.5) / n as f32,
                ((i * 7919) % n) as f32 / n as f32,
            );
            let (p, _) = sample(&t, &mut Tilted, share, u).unwrap();
            hits += in_child_0(p) as u32;
        }
        // P(child 0): product 9/(9+2+0+1) = 0.75, radiance 1/4.
        let expected = 0.75 * 0.75 + 0.25 * 0.25;
        let got = hits as f64 / n as f64;
        assert!((got - expected).abs() < 0.01, "{got} against {expected}");
    }

    #[test]
    fn shares_outside_zero_to_one_are_refused() {
        assert!(check_radiance_share(0.0).is_ok());
        assert!(check_radiance_share(0.99).is_ok());
        for bad in [1.0, -0.1, f32::NAN, f32::INFINITY] {
            assert!(check_radiance_share(bad).is_err(), "{bad}");
        }
    }
}
