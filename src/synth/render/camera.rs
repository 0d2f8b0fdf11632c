//! Cameras: a perspective (or orthographic) view given by eye, target and up, its projection to
//! the renderer's clip space, and the primary ray through a point of the image.
//!
//! **Clip space.** A point `p` maps to `(cx, cy, cd, w)`, all affine in `p`, so clipping can
//! interpolate linearly: `cx / w` and `cy / w` are normalised device coordinates in `[-1, 1]`
//! (x right, y up), and `cd / w` is the *nearness* `D`, affine in screen space and larger for
//! nearer points (`1 / distance` for a perspective view, `far − distance` for an orthographic
//! one). The rasteriser keeps the fragment with the largest `D`.

use glam::{Vec3, Vec4};

/// A view of the scene: perspective unless [`Camera::ortho_height`] is set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    /// Any vector not parallel to the view direction; the image's up is its part orthogonal to
    /// the view direction.
    pub up: Vec3,
    /// Vertical field of view of the perspective projection, in degrees.
    pub fov_y_deg: f32,
    /// `Some(h)`: an orthographic projection whose image spans `h` world units vertically
    /// (`fov_y_deg` is then ignored).
    pub ortho_height: Option<f32>,
}

impl Camera {
    pub fn perspective(eye: Vec3, target: Vec3, up: Vec3, fov_y_deg: f32) -> Camera {
        Camera { eye, target, up, fov_y_deg, ortho_height: None }
    }

    pub fn orthographic(eye: Vec3, target: Vec3, up: Vec3, height: f32) -> Camera {
        Camera { eye, target, up, fov_y_deg: 0.0, ortho_height: Some(height) }
    }

    /// A perspective camera looking at the centre of `bounds` (`(min, max)`) from the direction
    /// given by `azimuth_deg` (from +x toward +y, in the xy plane) and `elevation_deg` (from the
    /// xy plane toward +z), far enough that the bounding sphere fits the vertical field of view
    /// (`fov_y_deg`; with an image wider than high it then fits horizontally too). Elevation 90°
    /// looks straight down −z; the image's up is then the horizontal direction pointing away
    /// from the azimuth (+y for azimuth −90°).
    pub fn framing(bounds: (Vec3, Vec3), azimuth_deg: f32, elevation_deg: f32, fov_y_deg: f32) -> Camera {
        let (lo, hi) = bounds;
        let center = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(1e-6);
        let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
        let dir = Vec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
        // The derivative of `dir` with respect to the elevation: orthogonal to it at every angle.
        let up = Vec3::new(-el.sin() * az.cos(), -el.sin() * az.sin(), el.cos());
        let half = (fov_y_deg.clamp(1.0, 170.0) * 0.5).to_radians();
        let distance = radius / half.sin();
        Camera::perspective(center + dir * distance, center, up, fov_y_deg)
    }

    /// The orthonormal view frame `(right, up, forward)`.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let f = (self.target - self.eye).normalize_or(Vec3::NEG_Z);
        let mut r = f.cross(self.up);
        if r.length_squared() < 1e-12 {
            r = f.any_orthonormal_vector();
        }
        let r = r.normalize();
        (r, r.cross(f), f)
    }

    /// The projection of this camera onto an image of the given aspect ratio (width / height);
    /// `far` is a distance beyond every point drawn (used by the orthographic nearness only).
    pub fn projection(&self, aspect: f32, far: f32) -> Projection {
        let (right, up, forward) = self.basis();
        let kind = match self.ortho_height {
            Some(h) => {
                let hh = (h * 0.5).max(1e-12);
                ProjectionKind::Orthographic { half_w: hh * aspect, half_h: hh, far }
            }
            None => {
                let t = (self.fov_y_deg.clamp(0.01, 179.0) * 0.5).to_radians().tan();
                ProjectionKind::Perspective { tan_x: t * aspect, tan_y: t }
            }
        };
        Projection { eye: self.eye, right, up, forward, kind }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProjectionKind {
    Perspective { tan_x: f32, tan_y: f32 },
    Orthographic { half_w: f32, half_h: f32, far: f32 },
}

/// A camera's view frame and projection, ready to map points to clip space and pixels to rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    pub eye: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    pub kind: ProjectionKind,
}

impl Projection {
    /// An orthographic view along `forward` whose square image covers the sphere
    /// `(center, radius)` and whose depth range spans it.
    pub fn fitted_ortho(center: Vec3, radius: f32, forward: Vec3) -> Projection {
        let forward = forward.normalize_or(Vec3::NEG_Z);
        let hint = if forward.z.abs() < 0.9 { Vec3::Z } else { Vec3::Y };
        let right = forward.cross(hint).normalize();
        let up = right.cross(forward);
        let radius = radius.max(1e-6);
        let eye = center - forward * (radius * 2.0);
        Projection {
            eye,
            right,
            up,
            forward,
            kind: ProjectionKind::Orthographic { half_w: radius, half_h: radius, far: radius * 4.0 },
        }
    }

    /// Clip-space coordinates `(cx, cy, cd, w)` of a world point (see the module doc).
    #[inline]
    pub fn clip(&self, p: Vec3) -> Vec4 {
        let d = p - self.eye;
        let (vx, vy, vz) = (d.dot(self.right), d.dot(self.up), d.dot(self.forward));
        match self.kind {
            ProjectionKind::Perspective { tan_x, tan_y } => Vec4::new(vx / tan_x, vy / tan_y, 1.0, vz),
            ProjectionKind::Orthographic { half_w, half_h, far } => Vec4::new(vx / half_w, vy / half_h, far - vz, 1.0),
        }
    }

    /// The primary ray `(origin, direction)` through normalised device coordinates
    /// `(ndc_x, ndc_y)`; the direction is not normalised.
    #[inline]
    pub fn ray(&self, ndc_x: f32, ndc_y: f32) -> (Vec3, Vec3) {
        match self.kind {
            ProjectionKind::Perspective { tan_x, tan_y } => {
                (self.eye, self.forward + self.right * (ndc_x * tan_x) + self.up * (ndc_y * tan_y))
            }
            ProjectionKind::Orthographic { half_w, half_h, .. } => {
                (self.eye + self.right * (ndc_x * half_w) + self.up * (ndc_y * half_h), self.forward)
            }
        }
    }

    /// The smallest `w` a drawn point may have: the near plane of a perspective view (clipped
    /// against), none for an orthographic one.
    pub fn near_w(&self, near: f32) -> f32 {
        match self.kind {
            ProjectionKind::Perspective { .. } => near,
            ProjectionKind::Orthographic { .. } => f32::NEG_INFINITY,
        }
    }
}
