//! Models, synthetic quadtrees and shading configurations shared by the
//! product guiding tests.
#![allow(dead_code)]

use glam::{Vec2, Vec3};
use ltcguide::bsdf::{ConductorFresnel, Material, MaterialKind};
use ltcguide::directional::Cell;
use ltcguide::guiding::descent::{self, ChildWeights};
use ltcguide::guiding::guide::WeightModel;
use ltcguide::guiding::product::{
    CosineLobes, ProductCache, ProductModel, ProductWeights, guiding_ltc_options,
};
use ltcguide::guiding::quadtree::{QuadNode, QuadTree};
use ltcguide::integrator::guide::VertexContext;
use ltcguide::ltc::table::LtcTable;
use ltcguide::ltc::{LtcOptions, ProductKernel};
use ltcguide::math::Frame;
use ltcguide::sampling::{Rng, square_to_uniform_sphere};
use ltcguide::texture::Texture;

/// The paper's product at every vertex (its cosine product included), with
/// the LTC API's accurate options and no lobe reuse: the model these tests
/// check unless they say otherwise.
pub fn paper_model(table: &LtcTable, kernel: ProductKernel) -> ProductModel<'_> {
    ProductModel {
        table,
        kernel,
        options: LtcOptions::default(),
        radiance_only: false,
        cosine_lobes: CosineLobes::Product,
        product_vertices: 0,
        reuse_in_pixel: false,
        radiance_share: 0.0,
    }
}

/// [`paper_model`] with the LTC options every product render runs with
/// (`guiding_ltc_options`: sphere-clipped straddlers from level 2, chord
/// quads from level 4, centre rules), which trade accuracy for speed: the
/// sampler must still match its own pdf.
pub fn render_options_model(table: &LtcTable) -> ProductModel<'_> {
    ProductModel {
        options: guiding_ltc_options(),
        ..paper_model(table, ProductKernel::Simd)
    }
}

/// A random quadtree of about `n` nodes, depth ≤ 9, with some zero cells.
pub fn random_tree(rng: &mut Rng, n: usize) -> QuadTree {
    let mut nodes = vec![QuadNode {
        sums: [1.0, 0.5, 2.0, 0.7],
        children: [0; 4],
    }];
    let mut depth = vec![0u32];
    while nodes.len() < n {
        let i = (rng.next_u32() as usize) % nodes.len();
        let k = (rng.next_u32() % 4) as usize;
        if nodes[i].children[k] != 0 || depth[i] >= 9 || nodes[i].sums[k] == 0.0 {
            continue;
        }
        let sums = [0; 4].map(|_| {
            if rng.next_f32() < 0.15 {
                0.0
            } else {
                0.05 + 3.0 * rng.next_f32()
            }
        });
        nodes.push(QuadNode {
            sums,
            children: [0; 4],
        });
        depth.push(depth[i] + 1);
        nodes[i].children[k] = (nodes.len() - 1) as u32;
    }
    QuadTree::from_nodes(nodes).unwrap()
}

/// Probability of every χ² bin: each terminal cell's mass, spread over the
/// bins it overlaps in proportion to the overlap area.
pub fn exact_bin_probabilities(
    tree: &QuadTree,
    w: &mut impl ChildWeights,
    rx: usize,
    ry: usize,
) -> Vec<f64> {
    exact_bin_probabilities_in(tree, w, rx, ry, Cell::ROOT)
}

/// [`exact_bin_probabilities`] over the bins of the square of `zoom` alone
/// (in its own coordinates), unnormalised: they sum to P(zoom).
pub fn exact_bin_probabilities_in(
    tree: &QuadTree,
    w: &mut impl ChildWeights,
    rx: usize,
    ry: usize,
    zoom: Cell,
) -> Vec<f64> {
    let (zu, zv, zs) = zoom.square_bounds();
    let mut bins = vec![0f64; rx * ry];
    descent::for_each_terminal_cell(tree, w, |cell, mass| {
        let (u0, v0, size) = cell.square_bounds();
        // The cell in the zoom's coordinates, clipped to it.
        let (u0, v0, size) = ((u0 - zu) / zs, (v0 - zv) / zs, size / zs);
        if u0 >= 1.0 || v0 >= 1.0 || u0 + size <= 0.0 || v0 + size <= 0.0 {
            return;
        }
        let bin_range = |lo: f64, n: usize| {
            (
                (lo.max(0.0) * n as f64).floor() as usize,
                (((lo + size).min(1.0)) * n as f64).ceil() as usize,
            )
        };
        let ((bx0, bx1), (by0, by1)) = (bin_range(u0, rx), bin_range(v0, ry));
        for by in by0..by1.min(ry) {
            for bx in bx0..bx1.min(rx) {
                let ox =
                    ((bx + 1) as f64 / rx as f64).min(u0 + size) - (bx as f64 / rx as f64).max(u0);
                let oy =
                    ((by + 1) as f64 / ry as f64).min(v0 + size) - (by as f64 / ry as f64).max(v0);
                if ox > 0.0 && oy > 0.0 {
                    bins[by * rx + bx] += mass * ox * oy / (size * size);
                }
            }
        }
    });
    bins
}

pub fn material(alpha: f32, diffuse: bool) -> Material {
    let kind = if diffuse {
        MaterialKind::RoughPlastic {
            alpha,
            eta: 1.5,
            diffuse_reflectance: Texture::Constant(Vec3::splat(0.5)),
        }
    } else {
        MaterialKind::RoughConductor {
            alpha,
            fresnel: ConductorFresnel::None,
            specular_reflectance: Texture::Constant(Vec3::ONE),
        }
    };
    Material::new(kind, true).unwrap()
}

/// A shading configuration: normal, θ_o and material.
#[derive(Clone, Copy)]
pub struct Case {
    pub alpha: f32,
    pub diffuse: bool,
    pub theta_o_deg: f32,
    pub normal: Vec3,
}

pub fn weights_for<'c>(
    case: &Case,
    model: &'c ProductModel,
    rng: &mut Rng,
    cache: &'c mut ProductCache,
) -> Option<ProductWeights<'c>> {
    let phi = std::f32::consts::TAU * rng.next_f32();
    let bsdf = material(case.alpha, case.diffuse).at(Vec2::ZERO);
    weights_at(
        model,
        case.normal,
        wo_at(case.theta_o_deg, phi),
        &bsdf,
        cache,
    )
}

/// The local ω_o at polar angle `theta_o_deg` and azimuth `phi`.
pub fn wo_at(theta_o_deg: f32, phi: f32) -> Vec3 {
    let t = theta_o_deg.to_radians();
    Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
}

/// The product weights of the first vertex at the origin with `normal`,
/// local ω_o `wo` and `bsdf`.
pub fn weights_at<'c>(
    model: &'c ProductModel,
    normal: Vec3,
    wo: Vec3,
    bsdf: &ltcguide::bsdf::Bsdf,
    cache: &'c mut ProductCache,
) -> Option<ProductWeights<'c>> {
    let frame = Frame::from_normal(normal);
    model.weights(&first_vertex(&frame, wo, bsdf), cache)
}

/// The context of a path's first vertex at the origin, with the geometric
/// normal the shading one and no adjoint asked for.
pub fn first_vertex<'a>(
    frame: &'a Frame,
    wo: Vec3,
    bsdf: &'a ltcguide::bsdf::Bsdf,
) -> VertexContext<'a> {
    VertexContext {
        p: Vec3::ZERO,
        ng: frame.n,
        frame,
        wo_local: wo,
        bsdf,
        needs_adjoint: false,
        vertex_index: 0,
        revisit: false,
    }
}

pub fn cases(rng: &mut Rng) -> Vec<Case> {
    let mut v = Vec::new();
    for &(alpha, diffuse) in &[
        (1e-3, false),
        (0.05, false),
        (0.2, true),
        (0.4, false),
        (1.0, false),
        (1.0, true),
    ] {
        for &theta in &[0.0f32, 45.0, 80.0] {
            let normal = if rng.next_f32() < 0.2 {
                Vec3::Z
            } else {
                square_to_uniform_sphere(rng.next_2d())
            };
            v.push(Case {
                alpha,
                diffuse,
                theta_o_deg: theta,
                normal,
            });
        }
    }
    // Grazing beyond the paper's 85° switch: the radiance fallback.
    v.push(Case {
        alpha: 0.1,
        diffuse: false,
        theta_o_deg: 88.0,
        normal: Vec3::new(0.3, 0.2, 0.9).normalize(),
    });
    v
}
