//! The guides drawn under the model: a ground grid in the world's z = 0 plane and the world
//! axes at the origin (x red, y green, z blue: the usual RGB = xyz convention). World frame
//! z-up, metres, as everywhere in the display.
//!
//! The grid is sized from the scene's bounding sphere so that it reads at any scale: its step
//! is a "nice" length (1, 2 or 5 × 10ᵏ m) of about a quarter of the sphere's radius, it covers
//! 1.5 radii around the sphere centre's foot on z = 0 (snapped to the step, so small motions
//! do not move it), and every fifth line is darker. The axes are as long as the nearest whole
//! number of steps to 0.6 radii. The guides are depth-tested against the model (the model
//! hides them) and never written to the depth buffer.
//!
//! Entry points: [`Guides::around`], [`Guides::vertices`], [`GuideVertex`].

use nalgebra::Point3;

/// One vertex of the guide lines: world position (m) and linear RGBA colour.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GuideVertex {
    pub pos: [f32; 3],
    pub color: [f32; 4],
}

/// Linear RGBA of the minor grid lines (a little darker than the background).
pub const GRID_MINOR: [f32; 4] = [0.42, 0.47, 0.53, 1.0];
/// Linear RGBA of every fifth grid line.
pub const GRID_MAJOR: [f32; 4] = [0.25, 0.29, 0.34, 1.0];
/// Linear RGBA of the x, y and z axes.
pub const AXIS_COLORS: [[f32; 4]; 3] = [
    [0.85, 0.05, 0.04, 1.0],
    [0.05, 0.60, 0.08, 1.0],
    [0.06, 0.16, 0.95, 1.0],
];

/// The grid and axes for one scene size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guides {
    /// Distance between grid lines (m).
    pub step: f64,
    /// Grid centre in the z = 0 plane (x, y; m), a multiple of `step`.
    pub center: [f64; 2],
    /// Lines on each side of the centre: the grid spans ± `half_lines` × `step`.
    pub half_lines: u32,
    /// Length of each axis from the origin (m).
    pub axis_length: f64,
}

/// The largest 1, 2 or 5 × 10ᵏ not above `x` (`x` > 0).
fn nice_floor(x: f64) -> f64 {
    let p = 10f64.powf(x.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * p)
        .find(|v| *v <= x * (1.0 + 1e-12))
        .unwrap_or(p)
}

impl Guides {
    /// The guides for a scene whose bounding sphere is (`center`, `radius`, m); a unit sphere
    /// stands in for a degenerate one.
    pub fn around(center: Point3<f64>, radius: f64) -> Guides {
        let ok = radius.is_finite() && radius > 0.0 && center.iter().all(|c| c.is_finite());
        let (center, radius) = if ok {
            (center, radius)
        } else {
            (Point3::origin(), 1.0)
        };
        let step = nice_floor(radius / 4.0);
        let snap = |v: f64| (v / step).round() * step;
        Guides {
            step,
            center: [snap(center.x), snap(center.y)],
            half_lines: ((1.5 * radius / step).ceil() as u32).clamp(1, 200),
            axis_length: ((0.6 * radius / step).round().max(1.0)) * step,
        }
    }

    /// Half the side of the grid square (m).
    pub fn half_extent(&self) -> f64 {
        self.half_lines as f64 * self.step
    }

    /// The sphere (centre, radius) that holds the grid and the axes: what the depth range must
    /// enclose besides the model.
    pub fn bounds(&self) -> (Point3<f64>, f64) {
        let c = Point3::new(self.center[0], self.center[1], 0.0);
        let grid = self.half_extent() * std::f64::consts::SQRT_2;
        // The axes start at the origin, which may lie outside the grid.
        let axes = (Point3::origin() - c).norm() + self.axis_length;
        (c, grid.max(axes))
    }

    /// Line-list vertices (two per segment): the grid lines, then the x, y and z axes.
    pub fn vertices(&self) -> Vec<GuideVertex> {
        let n = self.half_lines as i64;
        let h = self.half_extent();
        let [cx, cy] = self.center;
        let mut out = Vec::with_capacity((4 * (2 * n + 1) + 6) as usize);
        let v = |x: f64, y: f64, z: f64, color: [f32; 4]| GuideVertex {
            pos: [x as f32, y as f32, z as f32],
            color,
        };
        for i in -n..=n {
            let t = i as f64 * self.step;
            // Every fifth line counted from the world origin, so majors stay put as the grid
            // re-centres.
            let major = |c: f64| ((c / self.step).round() as i64).rem_euclid(5) == 0;
            let color_x = if major(cx + t) {
                GRID_MAJOR
            } else {
                GRID_MINOR
            };
            let color_y = if major(cy + t) {
                GRID_MAJOR
            } else {
                GRID_MINOR
            };
            // A line of constant x, then one of constant y.
            out.push(v(cx + t, cy - h, 0.0, color_x));
            out.push(v(cx + t, cy + h, 0.0, color_x));
            out.push(v(cx - h, cy + t, 0.0, color_y));
            out.push(v(cx + h, cy + t, 0.0, color_y));
        }
        let l = self.axis_length;
        for (axis, color) in AXIS_COLORS.iter().enumerate() {
            let mut end = [0.0; 3];
            end[axis] = l;
            out.push(v(0.0, 0.0, 0.0, *color));
            out.push(v(end[0], end[1], end[2], *color));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_are_nice_lengths_about_a_quarter_radius() {
        assert_eq!(nice_floor(0.25), 0.2);
        assert_eq!(nice_floor(1.0), 1.0);
        assert_eq!(nice_floor(7.0), 5.0);
        assert_eq!(nice_floor(0.0031), 0.002);
        let g = Guides::around(Point3::new(0.1, -0.2, 0.6), 1.0);
        assert_eq!(g.step, 0.2);
        assert_eq!(g.center, [0.2, -0.2]);
        assert_eq!(g.half_lines, 8);
        assert!((g.axis_length - 0.6).abs() < 1e-12);
        let station = Guides::around(Point3::new(3.0, 0.0, 10.0), 60.0);
        assert_eq!(station.step, 10.0);
    }

    #[test]
    fn lines_lie_in_the_ground_plane_and_axes_start_at_the_origin() {
        let g = Guides::around(Point3::new(0.0, 0.0, 0.5), 1.0);
        let v = g.vertices();
        let grid = 4 * (2 * g.half_lines as usize + 1);
        assert_eq!(v.len(), grid + 6);
        assert!(v[..grid].iter().all(|p| p.pos[2] == 0.0));
        for (a, pair) in v[grid..].chunks(2).enumerate() {
            assert_eq!(pair[0].pos, [0.0; 3]);
            assert!((pair[1].pos[a] - g.axis_length as f32).abs() < 1e-6);
            assert_eq!(pair[0].color, AXIS_COLORS[a]);
        }
        // The line through the origin is a major one.
        let through_origin = v[..grid]
            .chunks(2)
            .find(|s| s[0].pos[0] == 0.0 && s[1].pos[0] == 0.0)
            .expect("a line x = 0");
        assert_eq!(through_origin[0].color, GRID_MAJOR);
        let (c, r) = g.bounds();
        assert!(v.iter().all(|p| {
            let q = Point3::new(p.pos[0] as f64, p.pos[1] as f64, p.pos[2] as f64);
            (q - c).norm() <= r + 1e-6
        }));
    }

    #[test]
    fn degenerate_spheres_get_the_unit_sphere() {
        assert_eq!(
            Guides::around(Point3::new(f64::NAN, 0.0, 0.0), 1.0),
            Guides::around(Point3::origin(), 1.0)
        );
        assert_eq!(
            Guides::around(Point3::origin(), 0.0),
            Guides::around(Point3::origin(), 1.0)
        );
    }
}
