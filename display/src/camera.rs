//! The camera: the seed's LOOK-FROM / LOOK-AT (world coordinates, metres), an up vector, a
//! vertical field of view, perspective or orthographic. World frame is z-up (the library's
//! convention). Projection is reversed-Z: the near plane maps to depth 1 and the far plane to 0,
//! which with a 32-bit float depth buffer gives nearly constant *relative* depth precision from
//! millimetres to kilometres (the float's exponent absorbs the 1/z). Near and far planes are
//! fitted to the scene's bounding sphere every frame; the near plane may come as close as 10⁻⁷
//! of the far one, so a camera a few centimetres from a small part of a kilometre-sized scene
//! still sees it (tests/render.rs, the centimetre cube on a 20 km plate).

use nalgebra::{Matrix4, Point3, Vector3};

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    Perspective,
    /// Orthographic; the visible half-height (m) is the look-at distance × tan(fov/2), so
    /// switching projection keeps the object's size at the look-at point.
    Orthographic,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub from: Point3<f64>,
    pub at: Point3<f64>,
    pub up: Vector3<f64>,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f64,
    pub projection: Projection,
}

/// The seed's example view direction (LOOK-FROM −100, 100, 45 towards LOOK-AT 0, 0, 8).
const DEFAULT_DIRECTION: [f64; 3] = [-100.0, 100.0, 37.0];

impl Camera {
    /// A camera looking at the sphere (`center`, `radius`) from the default direction, at the
    /// distance where the sphere fills the vertical field of view with a 10 % margin.
    pub fn framing(center: Point3<f64>, radius: f64) -> Camera {
        Self::framing_fov(center, radius, 40.0)
    }

    /// [`Camera::framing`] with a vertical field of view of `fov_y_deg` degrees.
    pub fn framing_fov(center: Point3<f64>, radius: f64, fov_y_deg: f64) -> Camera {
        let dir = Vector3::from(DEFAULT_DIRECTION).normalize();
        let r = if radius.is_finite() && radius > 0.0 {
            radius
        } else {
            1.0
        };
        let dist = 1.1 * r / (fov_y_deg.to_radians() / 2.0).sin();
        Camera {
            from: center + dir * dist,
            at: center,
            up: Vector3::z(),
            fov_y_deg,
            projection: Projection::Perspective,
        }
    }

    /// From `from` towards `at`, field of view kept.
    pub fn looking(from: Point3<f64>, at: Point3<f64>) -> Camera {
        Camera {
            from,
            at,
            ..Camera::framing(at, 1.0)
        }
    }

    /// Checks the camera can form a view: finite, from ≠ at, up not along the view direction.
    pub fn validate(&self) -> Result<(), String> {
        let finite = self
            .from
            .iter()
            .chain(self.at.iter())
            .chain(self.up.iter())
            .all(|v| v.is_finite());
        if !finite {
            return Err(format!(
                "camera has a non-finite coordinate: from {:?} at {:?} up {:?}",
                self.from, self.at, self.up
            ));
        }
        let d = self.at - self.from;
        if d.norm() < 1e-12 {
            return Err(format!("camera LOOK-FROM equals LOOK-AT ({:?})", self.from));
        }
        if d.normalize().cross(&self.up).norm() < 1e-9 {
            return Err(format!(
                "camera up {:?} is parallel to the view direction",
                self.up
            ));
        }
        if !(self.fov_y_deg > 0.0 && self.fov_y_deg < 179.0) {
            return Err(format!(
                "field of view {}° outside (0, 179)",
                self.fov_y_deg
            ));
        }
        Ok(())
    }

    pub fn view(&self) -> Matrix4<f64> {
        Matrix4::look_at_rh(&self.from, &self.at, &self.up)
    }

    /// Near and far planes that enclose the sphere (`center`, `radius`).
    fn clip_planes(&self, center: &Point3<f64>, radius: f64) -> (f64, f64) {
        let forward = (self.at - self.from).normalize();
        let depth = (center - self.from).dot(&forward);
        let r = radius.max(1e-9) * 1.01;
        let far = (depth + r).max(1e-6);
        let near = match self.projection {
            // Reversed-Z float depth resolves a near/far ratio of 10⁻⁷ (see the module note).
            Projection::Perspective => (depth - r).max(far * 1e-7),
            Projection::Orthographic => depth - r,
        };
        (near, far)
    }

    /// Projection for an image `aspect` = width / height, fitted to the scene sphere; reversed
    /// depth: near → 1, far → 0.
    pub fn projection_matrix(
        &self,
        aspect: f64,
        center: &Point3<f64>,
        radius: f64,
    ) -> Matrix4<f64> {
        let (n, f) = self.clip_planes(center, radius);
        let half = (self.fov_y_deg.to_radians() / 2.0).tan();
        match self.projection {
            Projection::Perspective => {
                let fy = 1.0 / half;
                Matrix4::new(
                    fy / aspect,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    fy,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    n / (f - n),
                    n * f / (f - n),
                    0.0,
                    0.0,
                    -1.0,
                    0.0,
                )
            }
            Projection::Orthographic => {
                let h = half * (self.at - self.from).norm();
                Matrix4::new(
                    1.0 / (h * aspect),
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    1.0 / h,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    1.0 / (f - n),
                    f / (f - n),
                    0.0,
                    0.0,
                    0.0,
                    1.0,
                )
            }
        }
    }

    /// The world ray through pixel (`x`, `y`) (origin top-left, pixel centres at +0.5) of a
    /// `width` × `height` image: origin and unit direction.
    pub fn ray(&self, x: f64, y: f64, width: u32, height: u32) -> (Point3<f64>, Vector3<f64>) {
        let aspect = width as f64 / height.max(1) as f64;
        let ndc_x = 2.0 * x / width.max(1) as f64 - 1.0;
        let ndc_y = 1.0 - 2.0 * y / height.max(1) as f64;
        let forward = (self.at - self.from).normalize();
        let right = forward.cross(&self.up).normalize();
        let up = right.cross(&forward);
        let half = (self.fov_y_deg.to_radians() / 2.0).tan();
        match self.projection {
            Projection::Perspective => {
                let d = forward + right * (ndc_x * half * aspect) + up * (ndc_y * half);
                (self.from, d.normalize())
            }
            Projection::Orthographic => {
                let h = half * (self.at - self.from).norm();
                let o = self.from + right * (ndc_x * h * aspect) + up * (ndc_y * h);
                (o, forward)
            }
        }
    }

    /// Turns the camera about LOOK-AT: `yaw` about the up axis, `pitch` about the camera's
    /// right axis (radians); pitch stops short of the poles.
    pub fn orbit(&mut self, yaw: f64, pitch: f64) {
        let offset = self.from - self.at;
        let up = self.up.normalize();
        let yawed =
            nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(up), yaw) * offset;
        let right = yawed.cross(&up);
        let angle_to_up = yawed.angle(&up);
        let pitch = pitch.clamp(
            -(angle_to_up - 0.01),
            std::f64::consts::PI - 0.01 - angle_to_up,
        );
        let rotated = if right.norm() > 1e-12 {
            nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(right), pitch)
                * yawed
        } else {
            yawed
        };
        self.from = self.at + rotated;
    }

    /// Moves LOOK-FROM and LOOK-AT together across the view by fractions of the visible
    /// height.
    pub fn pan(&mut self, dx: f64, dy: f64) {
        let forward = (self.at - self.from).normalize();
        let right = forward.cross(&self.up).normalize();
        let up = right.cross(&forward);
        let h = (self.fov_y_deg.to_radians() / 2.0).tan() * (self.at - self.from).norm() * 2.0;
        let shift = right * (-dx * h) + up * (dy * h);
        self.from += shift;
        self.at += shift;
    }

    /// Scales the distance from LOOK-AT by `factor` (< 1 moves closer).
    pub fn zoom(&mut self, factor: f64) {
        if factor.is_finite() && factor > 0.0 {
            self.from = self.at + (self.from - self.at) * factor;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn project(c: &Camera, p: Point3<f64>) -> Vector3<f64> {
        let m = c.projection_matrix(1.5, &Point3::origin(), 2.0) * c.view();
        let h = m * p.to_homogeneous();
        Vector3::new(h.x / h.w, h.y / h.w, h.z / h.w)
    }

    #[test]
    fn look_at_projects_to_the_centre_and_depth_is_in_range() {
        for projection in [Projection::Perspective, Projection::Orthographic] {
            let c = Camera {
                projection,
                ..Camera::looking(Point3::new(-10.0, 10.0, 4.5), Point3::new(0.0, 0.0, 0.8))
            };
            let ndc = project(&c, c.at);
            assert!(ndc.x.abs() < 1e-12 && ndc.y.abs() < 1e-12, "{ndc:?}");
            assert!((0.0..=1.0).contains(&ndc.z));
            // The scene sphere's nearest and farthest points stay inside [0, 1].
            let toward = (c.from - Point3::origin()).normalize() * 2.0;
            let z_near = project(&c, Point3::origin() + toward).z;
            let z_far = project(&c, Point3::origin() - toward).z;
            assert!((0.0..=1.0).contains(&z_near) && (0.0..=1.0).contains(&z_far));
            assert!(z_near > z_far, "reversed depth: nearer is larger");
        }
    }

    /// The pick ray through a pixel passes through the world point that projects to it.
    #[test]
    fn ray_inverts_projection() {
        for projection in [Projection::Perspective, Projection::Orthographic] {
            let c = Camera {
                projection,
                ..Camera::looking(Point3::new(3.0, -4.0, 2.0), Point3::new(0.1, 0.2, 0.3))
            };
            let p = Point3::new(0.5, -0.3, 0.9);
            let ndc = project(&c, p);
            let (w, h) = (300_u32, 200_u32);
            let x = (ndc.x + 1.0) / 2.0 * w as f64;
            let y = (1.0 - ndc.y) / 2.0 * h as f64;
            let (o, d) = c.ray(x, y, w, h);
            let miss = (p - o).cross(&d).norm();
            assert!(miss < 1e-9, "{projection:?}: ray misses by {miss}");
        }
    }

    #[test]
    fn orbit_keeps_distance_and_refuses_bad_cameras() {
        let mut c = Camera::framing(Point3::new(1.0, 2.0, 3.0), 0.5);
        let d0 = (c.from - c.at).norm();
        c.orbit(0.7, 3.0);
        assert!(((c.from - c.at).norm() - d0).abs() < 1e-9);
        assert!(c.validate().is_ok(), "pitch is clamped short of the pole");
        let same = Camera::looking(Point3::origin(), Point3::origin());
        assert!(
            same.validate()
                .expect_err("refused")
                .contains("LOOK-FROM equals LOOK-AT")
        );
        let down = Camera::looking(Point3::new(0.0, 0.0, 5.0), Point3::origin());
        assert!(down.validate().expect_err("refused").contains("parallel"));
        let nan = Camera::looking(Point3::new(f64::NAN, 0.0, 5.0), Point3::origin());
        assert!(nan.validate().expect_err("refused").contains("non-finite"));
    }
}
