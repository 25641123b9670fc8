//! The ray: an origin and a unit direction, what the camera casts and every shape intersects.

use glam::DVec3;

/// A ray with unit direction.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Origin.
    pub o: DVec3,
    /// Unit direction.
    pub d: DVec3,
}
