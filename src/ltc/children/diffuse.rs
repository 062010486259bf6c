//! The cosine lobe's child integrals (diffuse lobes, and GGX lobes rough
//! enough to count as cosines): quarter spheres in closed form at level 1, exact
//! clipping of straddling cells to [`EXACT_CROSSING_DEPTH`], and the cell
//! form factors (F·n, sphere-clipped across the horizon) deeper.

use super::super::form_factor;
use super::super::polygon::{
    MAX_CACHED_POLYGON, cached_cell_polygon, cell_integral_reference, clipped_edge_sum_z,
    transformed_cached_polygon,
};
use super::super::sphere_clip::clipped_integral;
use super::{EXACT_CLIP_DEPTH, ShadingLtc, cell_solid_angle, child_centre_directions, child_grid};
use crate::directional::Cell;
use glam::Vec3;
use std::f32::consts::PI;

impl ShadingLtc {
    /// Cosine-lobe integrals over the root's children (quarter spheres),
    /// in closed form ([`form_factor::cosine_root_children`]).
    pub(super) fn diffuse_root_children(&self) -> [f32; 4] {
        form_factor::cosine_root_children(self.normal)
    }

    /// n·ω⁺/π at the 4 children's centres × their solid angle.
    pub(super) fn diffuse_centres(&self, cell: Cell) -> [f32; 4] {
        let omega = cell_solid_angle(cell.depth + 1) / PI;
        child_centre_directions(cell).map(|w| self.normal.dot(w).max(0.0) * omega)
    }

    /// Cosine-lobe integrals by exact clipping in f64.
    pub fn diffuse_reference(&self, cell: Cell) -> [f32; 4] {
        let o = self.diffuse_map.determinant().signum();
        std::array::from_fn(|k| cell_integral_reference(cell.child(k), &self.diffuse_map, o) as f32)
    }

    /// Cosine-lobe integrals from cell form factors: F·n where the cell is
    /// above the horizon, sphere-clipped across it.
    pub fn diffuse_form_factors(&self, cell: Cell) -> [f32; 4] {
        if cell.depth < EXACT_CLIP_DEPTH {
            return self.diffuse_root_children();
        }
        if cell.depth < self.exact_crossing_depth {
            // Large cells: classify by the polygon, clip straddlers exactly.
            let mut buf = [Vec3::ZERO; MAX_CACHED_POLYGON];
            let scale = self.diffuse_orientation * (0.5 / PI);
            let zrow = self.diffuse_rows[2];
            let hxy = (zrow[0] * zrow[0] + zrow[1] * zrow[1]).sqrt();
            // Whole-parallel bounds of the mapped z = n·ω over a child's
            // two parallels (the node's 3, each bounded once) decide most
            // children at once (with a margin far above the vertices' f32
            // rounding); the rest are classified vertex by vertex with the
            // operations of `transform_rows`. Only straddlers are mapped in
            // full. (Bounding the 3 parallels once rather than 2 per child,
            // 8 square roots in a chain, took a fifth to a quarter off a
            // call at levels 3–5.)
            let (heights, _) = child_grid(cell);
            let parallel_bounds = heights.map(|z| {
                let r = (1.0 - z * z).max(0.0).sqrt();
                let c = zrow[2] * z;
                (c - r * hxy, c + r * hxy)
            });
            return std::array::from_fn(|k| {
                let child = cell.child(k);
                let [(lo0, hi0), (lo1, hi1)] =
                    [parallel_bounds[k & 1], parallel_bounds[(k & 1) + 1]];
                let (lo, hi) = (lo0.min(lo1), hi0.max(hi1));
                let (mut above, mut below) = (lo > 1e-5, hi < -1e-5);
                if !(above || below) {
                    (above, below) = (true, true);
                    for v in cached_cell_polygon(child).expect("coarse cell") {
                        let z = zrow[2].mul_add(v.z, zrow[1].mul_add(v.y, zrow[0] * v.x));
                        above &= z >= 0.0;
                        below &= z <= 0.0;
                    }
                }
                if above {
                    form_factor::form_factor(child).dot(self.normal).max(0.0)
                } else if below {
                    0.0
                } else {
                    let n = transformed_cached_polygon(child, &self.diffuse_rows, &mut buf);
                    (clipped_edge_sum_z(&buf[..n]) * scale).max(0.0)
                }
            });
        }
        let f = if cell.depth < form_factor::PRECOMPUTED_DEPTH {
            std::array::from_fn(|k| form_factor::form_factor(cell.child(k)))
        } else {
            form_factor::children_form_factors_f32(cell)
        };
        f.map(|f| clipped_integral(f.dot(self.normal), f.length_squared()))
    }
}
