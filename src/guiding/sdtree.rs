//! The spatial half of the SD-tree (Müller et al. 2017, §4–5).
//!
//! A binary tree over the scene's bounding box enlarged to a cube; a node at
//! depth d splits its box in half along axis d mod 3 (x → y → z). Each leaf
//! owns a pair of directional quadtrees — `sampling` (learnt from the
//! previous iteration, read-only during a pass) and `recording` (this
//! iteration's flux) — and the Adam states of its BSDF-sampling fraction
//! and of the product's radiance share (when it is learned).
//!
//! Split rule: after iteration k a leaf splits when its recorded statistical
//! weight (accepted samples) exceeds c·√(2^k). Iteration k renders 2^k
//! passes, so √(2^k) keeps the number of samples per leaf growing with the
//! square root of the budget, trading directional against spatial
//! resolution. c = 12000 is the reference implementation's default for
//! 1280×720; renders scale it with their pixel count
//! ([`default_split_threshold`]). On a split
//! both children copy the parent's trees, α and β, and the recorded flux and
//! weight are halved: in expectation each half-box received half, and the
//! mean-radiance estimate sum/weight is unchanged. Splitting repeats while a
//! child is still above the threshold.
//!
//! Thread safety: lookups and sampling take `&self` and the type is
//! `Send + Sync`; recording is done after a pass from merged buffers
//! (`record.rs`), never concurrently with sampling.

use super::adam::{AdamConfig, BsdfFraction};
use super::build::QuadTreeBuilder;
use super::quadtree::QuadTree;
use super::share_learning::{LearnedShare, ShareLearning};
use glam::Vec3;
use rayon::prelude::*;

/// Müller et al.'s c = 12000 was chosen for 1280×720 images.
pub const REFERENCE_SPLIT_THRESHOLD: f64 = 12000.0;
const REFERENCE_PIXELS: f64 = 1280.0 * 720.0;
/// Below this c, leaves hold too few samples for their quadtrees.
const MIN_SPLIT_THRESHOLD: f64 = 500.0;

/// The default c for an image of `pixels` pixels. Iteration k records
/// about pixels·2^k path vertices, so the same c gives a 640×360 image a
/// quarter of the leaves a 1280×720 image gets at the same iteration;
/// scaling c with the pixel count keeps the number of leaves (and thus the
/// spatial resolution learnt per iteration) independent of resolution.
/// Measured on veach-ajar (640×360, NEE on, per-sample variance of the
/// iterations at 4, 8, 16, 33 spp): c = 12000 → 70, 53, 40, 40 with 620
/// leaves; c = 4000 → 52, 38, 39, 37 with 2207 leaves; c = 1000 → 45, 37,
/// 34, 37 with 9234 leaves (unguided: 52).
pub fn default_split_threshold(pixels: usize) -> f64 {
    (REFERENCE_SPLIT_THRESHOLD * pixels as f64 / REFERENCE_PIXELS).max(MIN_SPLIT_THRESHOLD)
}

/// Refuses a split constant c (`--spatial-threshold`) that is not a
/// positive finite number: c ≤ 0 would split every box down to
/// [`MAX_SPATIAL_DEPTH`], and a NaN would never split one.
pub fn check_split_threshold(c: f64) -> Result<(), String> {
    if c > 0.0 && c.is_finite() {
        Ok(())
    } else {
        Err(format!(
            "--spatial-threshold must be a positive number, got {c}"
        ))
    }
}

/// Deepest spatial node; a cube of side 1 km is then cut to ~1 mm per axis.
pub const MAX_SPATIAL_DEPTH: u32 = 60;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SdTreeConfig {
    /// c in the split threshold c·√(2^k).
    pub split_threshold: f64,
    pub builder: QuadTreeBuilder,
    pub adam: AdamConfig,
    /// Product guiding's radiance share β learned per leaf from this
    /// starting value (`super::share_learning`); `None`: the guide's fixed
    /// β, or none.
    pub learned_radiance_share: Option<f32>,
    /// What the learned share minimises.
    pub share_learning: ShareLearning,
}

impl Default for SdTreeConfig {
    fn default() -> Self {
        SdTreeConfig {
            split_threshold: REFERENCE_SPLIT_THRESHOLD,
            builder: QuadTreeBuilder::default(),
            adam: AdamConfig::default(),
            learned_radiance_share: None,
            share_learning: ShareLearning::default(),
        }
    }
}

/// Spatial node: inner nodes store the index of their first child (the two
/// children are contiguous), leaves the index of their [`SdLeaf`].
#[derive(Clone, Copy, Debug, PartialEq)]
struct SpatialNode {
    first_child: u32,
    /// `NOT_A_LEAF` for inner nodes.
    leaf: u32,
}

const NOT_A_LEAF: u32 = u32::MAX;
/// Tag of an octree entry that is a leaf id.
const OCTANT_LEAF: u32 = 1 << 31;

#[derive(Clone, Debug)]
pub struct SdLeaf {
    /// Lower corner and extent of the leaf's box.
    pub min: Vec3,
    pub size: Vec3,
    pub depth: u32,
    /// Learnt from the previous iteration; what the renderer samples.
    pub sampling: QuadTree,
    /// Being filled by this iteration's records.
    pub recording: QuadTree,
    pub fraction: BsdfFraction,
    /// The product's radiance share, used when the tree learns it
    /// ([`SdTreeConfig::learned_radiance_share`]).
    pub share: LearnedShare,
}

/// Sizes of the whole structure.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SdTreeStats {
    pub leaves: usize,
    pub spatial_nodes: usize,
    /// Quadtree nodes over all leaves, sampling and recording trees.
    pub quadtree_nodes: usize,
    pub sampling_nodes: usize,
    pub max_quadtree_depth: u32,
    pub bytes: usize,
}

#[derive(Clone, Debug)]
pub struct SdTree {
    min: Vec3,
    side: f32,
    nodes: Vec<SpatialNode>,
    /// The same tree three levels (x, y, z) per node, for lookups: each
    /// entry is a leaf id tagged with `OCTANT_LEAF` or the index of the
    /// next octree node. A lookup then waits on a third as many dependent
    /// loads; rebuilt whenever `nodes` changes.
    octree: Vec<[u32; 8]>,
    octree_root: u32,
    leaves: Vec<SdLeaf>,
    pub config: SdTreeConfig,
}

impl SdTree {
    /// A single leaf covering the cube around the box [min, max], with empty
    /// quadtrees (so the guide is unavailable until the first refine).
    pub fn new(min: Vec3, max: Vec3, config: SdTreeConfig) -> Self {
        let extent = (max - min).max(Vec3::ZERO);
        // A degenerate or non-finite box still gets a usable cube.
        let mut side = extent.max_element();
        if !(side.is_finite() && side > 0.0) {
            side = 1.0;
        }
        let centre = if (min + max).is_finite() {
            0.5 * (min + max)
        } else {
            Vec3::ZERO
        };
        // A small margin so points on the box's faces fall strictly inside.
        let side = side * (1.0 + 1e-4);
        let min = centre - Vec3::splat(0.5 * side);
        SdTree {
            min,
            side,
            octree: Vec::new(),
            octree_root: OCTANT_LEAF,
            nodes: vec![SpatialNode {
                first_child: 0,
                leaf: 0,
            }],
            leaves: vec![SdLeaf {
                min,
                size: Vec3::splat(side),
                depth: 0,
                sampling: QuadTree::new(),
                recording: QuadTree::new(),
                fraction: BsdfFraction::default(),
                share: LearnedShare::starting_at(config.learned_radiance_share.unwrap_or(0.0)),
            }],
            config,
        }
    }

    /// The cube: lower corner and side.
    pub fn cube(&self) -> (Vec3, f32) {
        (self.min, self.side)
    }

    #[inline]
    pub fn leaves(&self) -> &[SdLeaf] {
        &self.leaves
    }

    #[inline]
    pub fn leaves_mut(&mut self) -> &mut [SdLeaf] {
        &mut self.leaves
    }

    #[inline]
    pub fn leaf(&self, id: u32) -> &SdLeaf {
        &self.leaves[id as usize]
    }

    /// The leaf containing `p`; points outside the cube (or non-finite
    /// coordinates) go to the nearest border leaf.
    #[inline]
    pub fn lookup(&self, p: Vec3) -> u32 {
        let x = (p - self.min) / self.side;
        let mut c = [unit(x.x), unit(x.y), unit(x.z)];
        let mut entry = self.octree_root;
        while entry & OCTANT_LEAF == 0 {
            let mut octant = 0;
            for (bit, axis) in c.iter_mut().enumerate() {
                let t = *axis * 2.0;
                let right = t >= 1.0;
                *axis = if right { t - 1.0 } else { t };
                octant |= (right as usize) << bit;
            }
            entry = self.octree[entry as usize][octant];
        }
        entry & !OCTANT_LEAF
    }

    /// [`Self::lookup`] on the binary tree itself: the octree's reference in
    /// the tests, nothing else needs it.
    #[cfg(test)]
    fn lookup_binary(&self, p: Vec3) -> u32 {
        let x = (p - self.min) / self.side;
        let mut c = [unit(x.x), unit(x.y), unit(x.z)];
        let mut node = self.nodes[0];
        loop {
            for axis in &mut c {
                if node.leaf != NOT_A_LEAF {
                    return node.leaf;
                }
                let t = *axis * 2.0;
                let right = t >= 1.0;
                *axis = if right { t - 1.0 } else { t };
                node = self.nodes[node.first_child as usize + right as usize];
            }
        }
    }

    /// Rebuilds the lookup octree from the binary nodes. Octree nodes sit at
    /// binary depths 0, 3, 6, …, where the next three splits are x, y, z.
    fn rebuild_octree(&mut self) {
        fn entry(nodes: &[SpatialNode], octree: &mut Vec<[u32; 8]>, n: usize) -> u32 {
            if nodes[n].leaf != NOT_A_LEAF {
                return nodes[n].leaf | OCTANT_LEAF;
            }
            let index = octree.len();
            octree.push([0; 8]);
            for octant in 0..8 {
                // Down at most three levels, stopping at a leaf.
                let mut m = n;
                for bit in 0..3 {
                    if nodes[m].leaf != NOT_A_LEAF {
                        break;
                    }
                    m = nodes[m].first_child as usize + (octant >> bit & 1);
                }
                octree[index][octant] = entry(nodes, octree, m);
            }
            index as u32
        }
        let mut octree = Vec::with_capacity(self.nodes.len() / 4 + 1);
        self.octree_root = entry(&self.nodes, &mut octree, 0);
        self.octree = octree;
    }

    /// Split threshold after iteration k: c·√(2^k).
    pub fn split_threshold(&self, iteration: u32) -> f64 {
        self.config.split_threshold * 2f64.powf(iteration as f64 * 0.5)
    }

    /// Between iterations: spatial splits from the iteration-k records, then
    /// every leaf's sampling tree is rebuilt from its recorded flux and a
    /// fresh recording tree with the new structure replaces the old one.
    pub fn refine(&mut self, iteration: u32) {
        self.refine_spatial(iteration);
        self.refine_directional();
    }

    /// Splits leaves whose recorded weight exceeds the threshold.
    pub fn refine_spatial(&mut self, iteration: u32) {
        let threshold = self.split_threshold(iteration);
        let mut stack: Vec<usize> = (0..self.nodes.len())
            .filter(|&i| self.nodes[i].leaf != NOT_A_LEAF)
            .collect();
        while let Some(n) = stack.pop() {
            let leaf_id = self.nodes[n].leaf as usize;
            let leaf = &self.leaves[leaf_id];
            // Weights are finite by construction (counts, halved on split).
            if leaf.recording.weight() <= threshold || leaf.depth >= MAX_SPATIAL_DEPTH {
                continue;
            }
            let axis = (leaf.depth % 3) as usize;
            let mut child = leaf.clone();
            child.recording.scale(0.5);
            child.depth += 1;
            child.size[axis] *= 0.5;
            let mut upper = child.clone();
            upper.min[axis] += child.size[axis];
            // The lower half keeps the parent's leaf id, so ids stay dense.
            let upper_id = self.leaves.len() as u32;
            self.leaves[leaf_id] = child;
            self.leaves.push(upper);
            let first = self.nodes.len() as u32;
            self.nodes.push(SpatialNode {
                first_child: 0,
                leaf: leaf_id as u32,
            });
            self.nodes.push(SpatialNode {
                first_child: 0,
                leaf: upper_id,
            });
            self.nodes[n] = SpatialNode {
                first_child: first,
                leaf: NOT_A_LEAF,
            };
            stack.push(first as usize);
            stack.push(first as usize + 1);
        }
        self.rebuild_octree();
    }

    /// Rebuilds every leaf's sampling tree from its recording tree.
    pub fn refine_directional(&mut self) {
        let builder = self.config.builder;
        self.leaves
            .par_iter_mut()
            .with_max_len(super::record::LEAVES_PER_JOB)
            .for_each(|leaf| {
                if let Some(t) = builder.build(&leaf.recording) {
                    leaf.sampling = t;
                }
                leaf.recording = leaf.sampling.structure_copy();
            });
    }

    /// The leaf's learned radiance share, when the tree learns it.
    #[inline]
    pub fn learned_radiance_share(&self, leaf: u32) -> Option<f32> {
        self.config
            .learned_radiance_share
            .map(|_| self.leaves[leaf as usize].share.share())
    }

    /// BSDF-sampling fraction of a leaf.
    #[inline]
    pub fn bsdf_fraction(&self, leaf: u32) -> f32 {
        self.leaves[leaf as usize].fraction.alpha(&self.config.adam)
    }

    pub fn stats(&self) -> SdTreeStats {
        let mut s = SdTreeStats {
            leaves: self.leaves.len(),
            spatial_nodes: self.nodes.len(),
            bytes: std::mem::size_of::<Self>()
                + self.nodes.capacity() * std::mem::size_of::<SpatialNode>()
                + self.octree.capacity() * std::mem::size_of::<[u32; 8]>()
                + self.leaves.capacity() * std::mem::size_of::<SdLeaf>(),
            ..Default::default()
        };
        for l in &self.leaves {
            s.quadtree_nodes += l.sampling.node_count() + l.recording.node_count();
            s.sampling_nodes += l.sampling.node_count();
            s.max_quadtree_depth = s.max_quadtree_depth.max(l.sampling.depth());
            // The QuadTree headers are inside SdLeaf already.
            s.bytes +=
                l.sampling.bytes() + l.recording.bytes() - 2 * std::mem::size_of::<QuadTree>();
        }
        s
    }
}

#[inline]
fn unit(x: f32) -> f32 {
    if x >= 0.0 {
        x.min(1.0 - f32::EPSILON / 2.0)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn is_send_and_sync() {
        fn check<T: Send + Sync>() {}
        check::<SdTree>();
        assert_eq!(std::mem::size_of::<SpatialNode>(), 8);
        eprintln!("SdLeaf: {} bytes", std::mem::size_of::<SdLeaf>());
    }

    /// The octree lookup finds the binary tree's leaf everywhere, on an
    /// unbalanced tree whose leaves end at every depth modulo 3.
    #[test]
    fn octree_lookup_matches_the_binary_tree() {
        let mut t = SdTree::new(
            Vec3::splat(-1.0),
            Vec3::new(3.0, 1.0, 2.0),
            SdTreeConfig::default(),
        );
        let mut rng = crate::sampling::Rng::new(11, 4);
        for iteration in 0..6 {
            t.config.split_threshold = 40.0;
            for _ in 0..3000 {
                // Clustered points: the tree refines unevenly.
                let u = rng.next_f32();
                let p = Vec3::new(u * u * 4.0 - 1.0, rng.next_f32() - 0.5, u * 3.0 - 1.0);
                let id = t.lookup_binary(p) as usize;
                t.leaves[id]
                    .recording
                    .record(glam::Vec2::splat(0.5), 1.0)
                    .unwrap();
            }
            t.refine_spatial(iteration);
        }
        let depths: std::collections::HashSet<u32> = t.leaves.iter().map(|l| l.depth % 3).collect();
        assert_eq!(depths.len(), 3, "leaves must end at every depth mod 3");
        for _ in 0..100_000 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 2.5;
            assert_eq!(t.lookup(p), t.lookup_binary(p), "{p}");
        }
        for p in [
            Vec3::splat(f32::NAN),
            Vec3::splat(f32::INFINITY),
            Vec3::splat(-1e30),
        ] {
            assert_eq!(t.lookup(p), t.lookup_binary(p));
        }
        assert!(t.leaves.len() > 50, "{}", t.leaves.len());
    }

    #[test]
    fn lookup_cycles_axes() {
        let mut t = SdTree::new(Vec3::ZERO, Vec3::ONE, SdTreeConfig::default());
        t.config.split_threshold = 0.5;
        // weight 3 > 0.5 → split; halves 1.5 → split; 0.75 → split; 0.375 stops.
        for _ in 0..3 {
            t.leaves[0]
                .recording
                .record(glam::Vec2::splat(0.5), 1.0)
                .unwrap();
        }
        t.refine_spatial(0);
        assert_eq!(t.leaves().len(), 8);
        let ids: std::collections::HashSet<u32> = (0..8)
            .map(|i| {
                let p = Vec3::new(
                    if i & 1 != 0 { 0.75 } else { 0.25 },
                    if i & 2 != 0 { 0.75 } else { 0.25 },
                    if i & 4 != 0 { 0.75 } else { 0.25 },
                );
                let id = t.lookup(p);
                let l = t.leaf(id);
                assert!(
                    (l.min.cmple(p) & p.cmplt(l.min + l.size)).all(),
                    "{p} {l:?}"
                );
                id
            })
            .collect();
        assert_eq!(ids.len(), 8);
        assert_eq!(t.lookup(Vec3::splat(f32::NAN)), t.lookup(Vec3::splat(-5.0)));
    }
}
