//! The shared descent: χ² of sampling against its own pdf, bit-identical pdf
//! of sampled points, and normalisation, on random trees with depth-20
//! leaves, zero-radiance subtrees and a product-like weight function.

use glam::{DVec2, Vec2};
use ltcguide::directional::Cell;
use ltcguide::guiding::descent::{
    ChildWeights, RadianceWeights, pdf, pdf_descend, sample, sample_descend,
};
use ltcguide::guiding::quadtree::{MAX_DEPTH, QuadNode, QuadTree};
use ltcguide::sampling::Rng;
use ltcguide::stats::chi2::{Chi2Config, chi2_square};

/// Random sums: a quarter of the children carry exactly zero, so some
/// subtrees hang under zero-radiance cells (unreachable) and some nodes have
/// all-zero sums (uniform fallback).
fn random_sums(rng: &mut Rng) -> [f32; 4] {
    if rng.next_f32() < 0.08 {
        return [0.0; 4];
    }
    [0; 4].map(|_| {
        if rng.next_f32() < 0.25 {
            0.0
        } else {
            0.05 + rng.next_f32()
        }
    })
}

/// A random tree of about `n` nodes plus a chain of nodes down to node depth
/// 19, i.e. leaf cells at depth 20.
fn random_tree(rng: &mut Rng, n: usize) -> QuadTree {
    QuadTree::from_nodes(random_nodes(rng, n, MAX_DEPTH)).unwrap()
}

/// Nodes of a random tree whose deepest leaf cells are at `max_leaf_depth`.
fn random_nodes(rng: &mut Rng, n: usize, max_leaf_depth: u32) -> Vec<QuadNode> {
    let mut nodes = vec![QuadNode {
        sums: [0.3, 0.9, 0.6, 0.2],
        children: [0; 4],
    }];
    let mut depth = vec![0u32];
    let grow = |nodes: &mut Vec<QuadNode>, depth: &mut Vec<u32>, i: usize, k: usize, sums| {
        let idx = nodes.len();
        nodes.push(QuadNode {
            sums,
            children: [0; 4],
        });
        depth.push(depth[i] + 1);
        nodes[i].children[k] = idx as u32;
        idx
    };
    // The deep chain, through cells that carry weight so it matters.
    let mut i = 0usize;
    while depth[i] + 1 < max_leaf_depth {
        let k = (rng.next_u32() % 4) as usize;
        let mut sums = random_sums(rng);
        sums[k] = sums[k].max(0.5);
        if nodes[i].sums[k] == 0.0 {
            nodes[i].sums[k] = 0.7;
        }
        i = grow(&mut nodes, &mut depth, i, k, sums);
    }
    while nodes.len() < n {
        let i = (rng.next_u32() as usize) % nodes.len();
        let k = (rng.next_u32() % 4) as usize;
        // Favour shallow growth so the tree is bushy, not a second chain.
        if nodes[i].children[k] == 0 && depth[i] + 1 < max_leaf_depth && depth[i] < 8 {
            let sums = random_sums(rng);
            grow(&mut nodes, &mut depth, i, k, sums);
        }
    }
    nodes
}

/// Emulates the product guider: w_k = L_k · D_k with D_k a smooth function
/// integrated (midpoint) over the child cell, plus deterministic failures
/// that exercise the fallbacks: all-zero weights under some depth-2 cells,
/// NaN under some depth-3 cells.
#[derive(Clone, Copy, Default)]
struct SmoothProduct;

fn lobe(u: f64, v: f64) -> f64 {
    0.15 + (-(u - 0.7).powi(2) * 8.0).exp() * (std::f64::consts::TAU * v).cos().powi(2)
}

impl ChildWeights for SmoothProduct {
    fn child_weights(&mut self, cell: Cell, radiance: [f32; 4]) -> [f32; 4] {
        if cell.depth == 2 && (cell.ix + cell.iy).is_multiple_of(2) {
            return [0.0; 4];
        }
        let mut w = [0f32; 4];
        for (k, w) in w.iter_mut().enumerate() {
            let (u0, v0, s) = cell.child(k).square_bounds();
            *w = radiance[k] * (lobe(u0 + 0.5 * s, v0 + 0.5 * s) * s * s) as f32;
        }
        if cell.depth == 3 && cell.ix.is_multiple_of(3) {
            w[1] = f32::NAN;
        }
        w
    }
}

/// ∫ pdf over the square, leaf by leaf (the pdf is constant on a leaf).
fn integrate<W: ChildWeights + Default>(tree: &QuadTree, within: Option<Cell>) -> f64 {
    let mut total = 0.0f64;
    tree.for_each_leaf(|cell, _, _| {
        if let Some(c) = within {
            let shift = cell.depth.saturating_sub(c.depth);
            if cell.depth < c.depth || cell.ix >> shift != c.ix || cell.iy >> shift != c.iy {
                return;
            }
        }
        let (u0, v0, s) = cell.square_bounds();
        let centre = Vec2::new((u0 + 0.5 * s) as f32, (v0 + 0.5 * s) as f32);
        total += pdf(tree, &mut W::default(), centre) as f64 * s * s;
    });
    total
}

const TRIALS: usize = 13;

fn chi2_cfg() -> Chi2Config {
    Chi2Config {
        significance: 0.01 / TRIALS as f64,
        ..Default::default()
    }
}

fn run_chi2<W: ChildWeights + Default>(
    tree: &QuadTree,
    seed: u64,
) -> ltcguide::stats::chi2::Chi2Outcome {
    let mut rng = Rng::new(seed, 11);
    let mut w = W::default();
    chi2_square(
        &chi2_cfg(),
        || sample(tree, &mut w, rng.next_2d()).map(|s| s.0),
        |p: DVec2| pdf(tree, &mut W::default(), p.as_vec2()) as f64,
    )
}

#[test]
fn sampling_matches_pdf_chi2_radiance_and_product_weights() {
    let mut rng = Rng::new(2024, 1);
    // 6 radiance trees + 6 product trees + the zoomed test below = TRIALS.
    for trial in 0..6 {
        let tree = random_tree(&mut rng, 60 + 40 * trial);
        assert_eq!(tree.depth(), MAX_DEPTH);
        let out = run_chi2::<RadianceWeights>(&tree, trial as u64);
        assert!(out.passed, "radiance trial {trial}: {}", out.message);
        assert!((out.pdf_integral - 1.0).abs() < 2e-3, "{}", out.message);
        let out = run_chi2::<SmoothProduct>(&tree, 100 + trial as u64);
        assert!(out.passed, "product trial {trial}: {}", out.message);
        assert!((out.pdf_integral - 1.0).abs() < 2e-3, "{}", out.message);
    }
}

const ZOOM: u32 = 14;

/// A chain of heavy cells (57 : 1 : 1 : 1) down to a depth-14 cell C, so C
/// carries about half the mass, and a random tree below C down to depth 20.
fn zoom_tree(rng: &mut Rng) -> (QuadTree, Cell) {
    let mut nodes = vec![];
    let mut cell = Cell::ROOT;
    for d in 0..ZOOM {
        let k = (rng.next_u32() % 4) as usize;
        let mut sums = [1.0; 4];
        sums[k] = 57.0;
        let mut children = [0; 4];
        children[k] = d + 1;
        nodes.push(QuadNode { sums, children });
        cell = cell.child(k);
    }
    // Below C: a random subtree reaching depth 20 in absolute terms.
    let base = nodes.len() as u32;
    for mut n in random_nodes(rng, 150, MAX_DEPTH - ZOOM) {
        for c in &mut n.children {
            if *c != 0 {
                *c += base;
            }
        }
        nodes.push(n);
    }
    let tree = QuadTree::from_nodes(nodes).unwrap();
    (tree, cell)
}

/// A heavy chain down to a depth-14 cell C, and random structure to depth 20
/// below it: χ² of the distribution conditioned on C, in C's own coordinates,
/// resolves the deepest levels that the full-square test cannot see.
#[test]
fn deep_levels_pass_chi2_when_zoomed_in() {
    let mut rng = Rng::new(77, 3);
    let (tree, cell) = zoom_tree(&mut rng);
    assert_eq!(tree.depth(), MAX_DEPTH);
    let p_c = integrate::<RadianceWeights>(&tree, Some(cell));
    assert!(p_c > 0.3, "P(C) = {p_c}");
    let (u0, v0, s) = cell.square_bounds();
    let scale = 1.0 / s;
    let mut rng = Rng::new(5, 5);
    let out = chi2_square(
        &chi2_cfg(),
        || loop {
            let (p, _) = sample(&tree, &mut RadianceWeights, rng.next_2d()).unwrap();
            let q = DVec2::new((p.x as f64 - u0) * scale, (p.y as f64 - v0) * scale);
            if (0.0..1.0).contains(&q.x) && (0.0..1.0).contains(&q.y) {
                return Some(q.as_vec2());
            }
        },
        |q: DVec2| {
            // Round down, not to nearest: in C's coordinates f32 spacing is
            // 2^-10, and rounding up would move points below a cell edge
            // into the next cell and bias the expected counts.
            let p = Vec2::new(floor_f32(u0 + q.x * s), floor_f32(v0 + q.y * s));
            pdf(&tree, &mut RadianceWeights, p) as f64 * s * s / p_c
        },
    );
    assert!(out.passed, "{}", out.message);
}

fn floor_f32(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x { f.next_down() } else { f }
}

#[test]
fn an_inconsistent_pdf_fails_chi2() {
    let mut rng = Rng::new(2024, 1);
    let tree = random_tree(&mut rng, 100);
    let mut srng = Rng::new(9, 9);
    // Sample with the product weights, claim the radiance pdf.
    let out = chi2_square(
        &chi2_cfg(),
        || sample(&tree, &mut SmoothProduct, srng.next_2d()).map(|s| s.0),
        |p: DVec2| pdf(&tree, &mut RadianceWeights, p.as_vec2()) as f64,
    );
    assert!(!out.passed, "{}", out.message);
    // A subtler error: the right pdf, 10 % too high on the left half and
    // renormalised.
    let out = chi2_square(
        &chi2_cfg(),
        || sample(&tree, &mut RadianceWeights, srng.next_2d()).map(|s| s.0),
        |p: DVec2| {
            let f = if p.x < 0.5 { 1.1 } else { 0.9 };
            f * pdf(&tree, &mut RadianceWeights, p.as_vec2()) as f64
        },
    );
    assert!(!out.passed, "{}", out.message);
}

#[test]
fn pdf_of_sampled_point_is_bit_identical_and_in_its_leaf() {
    let mut rng = Rng::new(31, 4);
    for trial in 0..8 {
        // Odd trials use a tree whose depth-20 leaves are actually reached.
        let tree = if trial % 2 == 0 {
            random_tree(&mut rng, 200)
        } else {
            zoom_tree(&mut rng).0
        };
        let mut deepest = 0;
        for i in 0..20_000 {
            // Alternate random and stratified-edge inputs (0 and 1−ε).
            let u = if i % 10 == 0 {
                Vec2::new(
                    (i % 3) as f32 * 0.49999997,
                    if i % 20 == 0 { 0.99999994 } else { 0.0 },
                )
            } else {
                rng.next_2d()
            };
            for product in [false, true] {
                let (d, p2) = if product {
                    let d = sample_descend(&tree, &mut SmoothProduct, u).unwrap();
                    (d, pdf_descend(&tree, &mut SmoothProduct, d.point))
                } else {
                    let d = sample_descend(&tree, &mut RadianceWeights, u).unwrap();
                    (d, pdf_descend(&tree, &mut RadianceWeights, d.point))
                };
                assert!(d.point.x >= 0.0 && d.point.x < 1.0 && d.point.y >= 0.0 && d.point.y < 1.0);
                assert!(d.pdf_square > 0.0 && d.pdf_square.is_finite());
                assert_eq!(
                    d.pdf_square.to_bits(),
                    p2.0.to_bits(),
                    "trial {trial} u {u:?}"
                );
                assert_eq!(d.root_total.to_bits(), p2.1.to_bits());
                deepest = deepest.max(tree.leaf_cell(d.point).depth);
            }
        }
        if trial % 2 == 1 {
            assert_eq!(deepest, MAX_DEPTH, "samples never reached depth 20");
        }
    }
}

#[test]
fn pdf_integrates_to_one_leaf_by_leaf() {
    let mut rng = Rng::new(8, 8);
    for _ in 0..10 {
        let tree = random_tree(&mut rng, 300);
        let a = integrate::<RadianceWeights>(&tree, None);
        let b = integrate::<SmoothProduct>(&tree, None);
        assert!((a - 1.0).abs() < 1e-5, "radiance ∫pdf = {a}");
        assert!((b - 1.0).abs() < 1e-5, "product ∫pdf = {b}");
    }
    // An all-zero root is the only case without a distribution.
    assert_eq!(integrate::<RadianceWeights>(&QuadTree::new(), None), 0.0);
    assert!(sample(&QuadTree::new(), &mut SmoothProduct, Vec2::splat(0.3)).is_none());
}

#[test]
fn descent_is_stratified() {
    // A 64×64 stratified input on a one-node tree with unequal weights: each
    // child receives its exact share of strata, not a binomial count.
    let root = QuadNode {
        sums: [1.0, 2.0, 3.0, 2.0],
        ..Default::default()
    };
    let tree = QuadTree::from_nodes(vec![root]).unwrap();
    let mut counts = [0usize; 4];
    for j in 0..64 {
        for i in 0..64 {
            let u = Vec2::new((i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 64.0);
            let (p, _) = sample(&tree, &mut RadianceWeights, u).unwrap();
            counts[(p.x >= 0.5) as usize | (((p.y >= 0.5) as usize) << 1)] += 1;
        }
    }
    // Columns get 1/2 each; rows 1/4 : 3/4 on the left, 1/2 : 1/2 on the
    // right, all exactly.
    assert_eq!(counts, [512, 1024, 1536, 1024]);
}

/// Hemisphere weights (`guiding::support`) on random trees and normals: the
/// same χ², bit-identity and normalisation checks as the radiance and
/// product weights. Sampling keeps one weights object across samples and
/// the pdf takes a fresh one per point, so the per-vertex memo and the
/// remembered wholly-above cell cannot make a value depend on what was
/// computed before.
#[test]
fn hemisphere_weights_sample_their_own_pdf() {
    use ltcguide::directional::square_to_dir;
    use ltcguide::guiding::descent::for_each_terminal_cell;
    use ltcguide::guiding::support::HemisphereWeights;
    let mut rng = Rng::new(404, 2);
    for trial in 0..4 {
        let tree = random_tree(&mut rng, 80 + 60 * trial);
        let n = match trial {
            0 => glam::Vec3::new(0.0, 0.0, 1.0),
            _ => square_to_dir(rng.next_2d()),
        };
        // Normalisation over the terminal cells, in depth-first order, and
        // the probability below the plane (by 64 points per terminal cell),
        // against the sphere's: 0 to 8 % of it on these trees, whose
        // zero-radiance children leave some nodes with radiance only below
        // (the descent then takes the radiance), and where refinement stops
        // at sub-cells within 1.5 of each other or under 1e-3 of the mass.
        let below_of = |cells: Vec<(Cell, f64)>| {
            let (mut total, mut below) = (0.0, 0.0);
            for (cell, p) in cells {
                total += p;
                let (u0, v0, s) = cell.square_bounds();
                let points = (0..64).filter(|i| {
                    let q = Vec2::new(
                        (u0 + (i % 8) as f64 / 8.0 * s + s / 16.0) as f32,
                        (v0 + (i / 8) as f64 / 8.0 * s + s / 16.0) as f32,
                    );
                    n.dot(square_to_dir(q)) < 0.0
                });
                below += p * points.count() as f64 / 64.0;
            }
            (total, below)
        };
        let terminal = |mut weights: &mut dyn ChildWeights| {
            let mut cells = Vec::new();
            for_each_terminal_cell(&tree, &mut weights, |c, p| cells.push((c, p)));
            cells
        };
        let (total, below) = below_of(terminal(&mut HemisphereWeights::new(n)));
        let (_, sphere_below) = below_of(terminal(&mut RadianceWeights));
        eprintln!("trial {trial}: below the plane {below:.4} (sphere {sphere_below:.4})");
        assert!((total - 1.0).abs() < 1e-5, "trial {trial}: Σ p = {total}");
        assert!(
            below < 0.1 * sphere_below,
            "trial {trial}: {below} of the mass below the plane, sphere {sphere_below}"
        );

        let mut srng = Rng::new(trial as u64, 17);
        let mut kept = HemisphereWeights::new(n);
        let out = chi2_square(
            &chi2_cfg(),
            || sample(&tree, &mut kept, srng.next_2d()).map(|s| s.0),
            |p: DVec2| pdf(&tree, &mut HemisphereWeights::new(n), p.as_vec2()) as f64,
        );
        assert!(out.passed, "hemisphere trial {trial}: {}", out.message);
        assert!((out.pdf_integral - 1.0).abs() < 2e-3, "{}", out.message);

        let mut kept = HemisphereWeights::new(n);
        for _ in 0..5000 {
            let d = sample_descend(&tree, &mut kept, srng.next_2d()).unwrap();
            let again = pdf_descend(&tree, &mut kept, d.point);
            let fresh = pdf_descend(&tree, &mut HemisphereWeights::new(n), d.point);
            assert_eq!(d.pdf_square.to_bits(), again.0.to_bits());
            assert_eq!(d.pdf_square.to_bits(), fresh.0.to_bits());
            assert_eq!(d.root_total.to_bits(), fresh.1.to_bits());
        }
    }
}
