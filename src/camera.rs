//! Mitsuba's perspective pinhole camera (scene pack README, "Sensor"):
//! camera space looks down +z with +y up and +x to the LEFT of the image.

use glam::{Mat4, Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    X,
    Y,
    Smaller,
    Larger,
}

#[derive(Clone, Debug)]
pub struct Camera {
    pub to_world: Mat4,
    pub width: usize,
    pub height: usize,
    /// tan(fov_x / 2) and tan(fov_y / 2).
    tan_half: Vec2,
    origin: Vec3,
}

impl Camera {
    /// `fov_degrees` is the full field of view along `axis`.
    pub fn new(
        to_world: Mat4,
        fov_degrees: f32,
        axis: FovAxis,
        width: usize,
        height: usize,
    ) -> Self {
        let aspect = width as f32 / height as f32;
        let along_x = match axis {
            FovAxis::X => true,
            FovAxis::Y => false,
            FovAxis::Smaller => width <= height,
            FovAxis::Larger => width >= height,
        };
        let t = (0.5 * fov_degrees.to_radians()).tan();
        let tan_half = if along_x {
            Vec2::new(t, t / aspect)
        } else {
            Vec2::new(t * aspect, t)
        };
        Camera {
            to_world,
            width,
            height,
            tan_half,
            origin: to_world.transform_point3(Vec3::ZERO),
        }
    }

    /// World ray (origin, unit direction) through film position `film`
    /// (pixels; x right, y down, (0,0) the top-left corner).
    #[inline]
    pub fn ray(&self, film: Vec2) -> (Vec3, Vec3) {
        let hw = 0.5 * self.width as f32;
        let hh = 0.5 * self.height as f32;
        let d = Vec3::new(
            (hw - film.x) / hw * self.tan_half.x,
            (hh - film.y) / hh * self.tan_half.y,
            1.0,
        );
        let dir = self.to_world.transform_vector3(d).normalize();
        (self.origin, dir)
    }

    pub fn position(&self) -> Vec3 {
        self.origin
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plus_x_points_left_and_fov_spans_the_width() {
        let cam = Camera::new(Mat4::IDENTITY, 90.0, FovAxis::X, 200, 100);
        let (_, centre) = cam.ray(Vec2::new(100.0, 50.0));
        assert!((centre - Vec3::Z).length() < 1e-6);
        let (_, left_edge) = cam.ray(Vec2::new(0.0, 50.0));
        // tan(45°) = 1 at the left edge, which is camera +x.
        assert!((left_edge - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6);
        let (_, top) = cam.ray(Vec2::new(100.0, 0.0));
        assert!((top - Vec3::new(0.0, 0.5, 1.0).normalize()).length() < 1e-6);
    }
}
