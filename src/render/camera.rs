//! The look-at camera and the primary rays through image positions.

use super::Ray;
use glam::DVec3;

/// Camera: look-at with a horizontal field of view.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Eye position.
    pub eye: DVec3,
    /// Point looked at.
    pub target: DVec3,
    /// Up vector.
    pub up: DVec3,
    /// Horizontal field of view, degrees.
    pub fov_deg: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Camera {
    /// The primary ray through continuous image position (x, y) ∈ [0, W] × [0, H].
    pub fn ray(&self, x: f64, y: f64) -> Ray {
        self.frame().ray(x, y)
    }

    /// The camera's basis and image-plane scale, computed once for many rays.
    pub fn frame(&self) -> CameraFrame {
        let f = (self.target - self.eye).normalize();
        let r = f.cross(self.up).normalize();
        let tx = (0.5 * self.fov_deg.to_radians()).tan();
        CameraFrame {
            eye: self.eye,
            // One pixel step along x and y, and the image corner, in world directions.
            dx: r * (2.0 * tx / self.width as f64),
            dy: r.cross(f) * (-2.0 * tx / self.width as f64),
            corner: f - r * tx + r.cross(f) * (tx * self.height as f64 / self.width as f64),
        }
    }
}

/// A camera's precomputed basis ([`Camera::frame`]).
#[derive(Clone, Copy, Debug)]
pub struct CameraFrame {
    eye: DVec3,
    dx: DVec3,
    dy: DVec3,
    corner: DVec3,
}

impl CameraFrame {
    /// The primary ray through continuous image position (x, y) ∈ [0, W] × [0, H].
    #[inline]
    pub fn ray(&self, x: f64, y: f64) -> Ray {
        Ray {
            o: self.eye,
            d: (self.corner + x * self.dx + y * self.dy).normalize(),
        }
    }
}
