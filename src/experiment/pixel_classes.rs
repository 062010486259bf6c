//! Pixels grouped by what product guiding does at their first non-delta
//! vertex, so that a variance ratio can be split where the two guides
//! differ and where they cannot.
//!
//! With the default `--cosine-lobes radiance`, a vertex whose lobes are all
//! cosines (diffuse, plastic without a glossy coat, GGX rougher than
//! `rough_as_diffuse_above`) takes radiance weights in a product run too;
//! only a vertex with a glossy GGX lobe is where the product's own
//! distribution acts first.

use crate::integrator::first_vertex::at_pixel_centre;
use crate::ltc::LtcOptions;
use crate::scene::Scene;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelClass {
    /// GGX lobes the product integrates as such (α ≤ 0.5) carry at least
    /// half the lobes' weight (rough conductors).
    Glossy,
    /// Such a lobe is there but carries less than the cosine lobes (a
    /// plastic's coat over its diffuse base).
    GlossyCoat,
    /// Only cosine lobes: the product takes radiance weights here.
    Cosine,
    /// The camera ray leaves the scene, meets only delta surfaces, or ends
    /// at a surface that reflects nothing.
    NoVertex,
}

impl PixelClass {
    pub const ALL: [PixelClass; 4] = [
        PixelClass::Glossy,
        PixelClass::GlossyCoat,
        PixelClass::Cosine,
        PixelClass::NoVertex,
    ];

    pub fn label(self) -> &'static str {
        match self {
            PixelClass::Glossy => "glossy GGX lobe (α ≤ 0.5), most of the weight",
            PixelClass::GlossyCoat => "glossy coat (α ≤ 0.5) over cosine lobes",
            PixelClass::Cosine => "cosine lobes only",
            PixelClass::NoVertex => "no vertex to guide (none, delta only or black)",
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// The class of every pixel (row-major), from its centre's first vertex.
pub fn classify(scene: &Scene) -> Vec<PixelClass> {
    let opts = LtcOptions::default();
    let n = scene.camera.width * scene.camera.height;
    (0..n)
        .map(|i| match at_pixel_centre(scene, i) {
            None => PixelClass::NoVertex,
            Some(v) => {
                let lobes = v.bsdf.lobes(v.wo_local);
                let (mut glossy, mut cosine) = (0.0, lobes.diffuse);
                for g in &lobes.ggx[..lobes.ggx_count] {
                    if opts.integrates_as_cosine(g.alpha) {
                        cosine += g.weight;
                    } else {
                        glossy += g.weight;
                    }
                }
                if !(glossy > 0.0) {
                    PixelClass::Cosine
                } else if glossy >= cosine {
                    PixelClass::Glossy
                } else {
                    PixelClass::GlossyCoat
                }
            }
        })
        .collect()
}

/// Per-class sums of a per-pixel quantity, in [`PixelClass::ALL`]'s order.
pub fn class_sums(classes: &[PixelClass], values: impl Iterator<Item = f64>) -> [f64; 4] {
    let mut sums = [0.0; 4];
    for (c, v) in classes.iter().zip(values) {
        sums[c.index()] += v;
    }
    sums
}

/// Pixels per class, in [`PixelClass::ALL`]'s order.
pub fn class_counts(classes: &[PixelClass]) -> [usize; 4] {
    let mut counts = [0; 4];
    for c in classes {
        counts[c.index()] += 1;
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_and_counts_follow_the_classes() {
        let classes = [
            PixelClass::Cosine,
            PixelClass::Glossy,
            PixelClass::Cosine,
            PixelClass::NoVertex,
            PixelClass::GlossyCoat,
        ];
        assert_eq!(class_counts(&classes), [1, 1, 2, 1]);
        let sums = class_sums(&classes, [1.0, 2.0, 4.0, 8.0, 16.0].into_iter());
        assert_eq!(sums, [2.0, 16.0, 5.0, 8.0]);
    }
}
