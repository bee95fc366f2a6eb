//! A walking path: a polyline whose corners are rounded with circular arcs, parametrised by arc
//! length, so that position is C¹ and heading is continuous.

use nalgebra::Vector2;

/// One piece of a [`Path`].
#[derive(Debug, Clone, Copy, PartialEq)]
enum Piece {
    /// A straight segment from `start` along the unit vector `dir`.
    Line {
        start: Vector2<f64>,
        dir: Vector2<f64>,
    },
    /// A circular arc around `center`, starting at polar angle `angle0_rad`, turning left
    /// (`turn = +1`) or right (`turn = -1`).
    Arc {
        center: Vector2<f64>,
        radius_m: f64,
        angle0_rad: f64,
        turn: f64,
    },
}

/// Length of the window over which [`Path::smooth_heading_rad`] averages the tangent heading,
/// metres. The box average turns the heading's piecewise-constant rate (0 on lines, 1/r on arcs)
/// into a continuous one, so that body parts away from the pelvis have continuous velocities
/// (their accelerations step by at most `v² · |Δκ| · lever / window`, about 1.5 m/s² at a wrist).
pub const HEADING_WINDOW_M: f64 = 0.6;

/// A path through the scene (metres, horizontal plane).
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    /// Pieces with the arc length at which each starts.
    pieces: Vec<(f64, Piece)>,
    /// Per piece: unwrapped heading at its start, heading rate (rad/m), and the integral of the
    /// unwrapped heading from s = 0 to its start (rad·m).
    heading_integral: Vec<(f64, f64, f64)>,
    length_m: f64,
}

/// A point on a [`Path`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// Position, metres.
    pub position_m: Vector2<f64>,
    /// Heading of the tangent, radians counter-clockwise from +x.
    pub heading_rad: f64,
}

fn heading(v: &Vector2<f64>) -> f64 {
    v.y.atan2(v.x)
}

impl Path {
    /// Builds a path through `waypoints` (at least two, consecutive ones distinct), rounding every
    /// corner with an arc of radius up to `corner_radius_m`, shrunk where the neighbouring
    /// segments are too short to hold it (the arc never uses more than half of a segment).
    pub fn new(waypoints: &[[f64; 2]], corner_radius_m: f64) -> Option<Path> {
        let pts: Vec<Vector2<f64>> = waypoints.iter().map(|w| Vector2::new(w[0], w[1])).collect();
        if pts.len() < 2 {
            return None;
        }
        let mut dirs = Vec::with_capacity(pts.len() - 1);
        let mut lens = Vec::with_capacity(pts.len() - 1);
        for w in pts.windows(2) {
            let d = w[1] - w[0];
            let n = d.norm();
            if !(n > 1e-6 && n.is_finite()) {
                return None;
            }
            dirs.push(d / n);
            lens.push(n);
        }
        // Tangent length cut from each end of each segment by the corner arcs.
        let num_corners = pts.len() - 2;
        let mut corner = Vec::with_capacity(num_corners); // (tangent length, radius, turn angle)
        for c in 0..num_corners {
            let (u1, u2) = (dirs[c], dirs[c + 1]);
            let phi = (u1.x * u2.y - u1.y * u2.x).atan2(u1.dot(&u2));
            let half_tan = (phi.abs() / 2.0).tan();
            let max_cut = 0.5 * lens[c].min(lens[c + 1]);
            let mut r = corner_radius_m.max(0.0);
            if half_tan * r > max_cut {
                r = if half_tan > 0.0 {
                    max_cut / half_tan
                } else {
                    r
                };
            }
            if phi.abs() < 1e-9 || !r.is_finite() {
                corner.push((0.0, 0.0, 0.0));
            } else {
                corner.push((r * half_tan, r, phi));
            }
        }
        let mut pieces = Vec::new();
        let mut s = 0.0;
        for (k, (dir, len)) in dirs.iter().zip(&lens).enumerate() {
            let cut_start = if k > 0 { corner[k - 1].0 } else { 0.0 };
            let cut_end = if k < num_corners { corner[k].0 } else { 0.0 };
            let start = pts[k] + dir * cut_start;
            pieces.push((s, Piece::Line { start, dir: *dir }));
            s += (len - cut_start - cut_end).max(0.0);
            if k < num_corners {
                let (_, r, phi) = corner[k];
                if r > 0.0 {
                    let turn = phi.signum();
                    let arc_start = pts[k + 1] - dir * cut_end;
                    // Centre is to the left (turn > 0) or right of the direction of travel.
                    let normal = Vector2::new(-dir.y, dir.x) * turn;
                    let center = arc_start + normal * r;
                    let rel = arc_start - center;
                    pieces.push((
                        s,
                        Piece::Arc {
                            center,
                            radius_m: r,
                            angle0_rad: rel.y.atan2(rel.x),
                            turn,
                        },
                    ));
                    s += r * phi.abs();
                }
            }
        }
        let mut path = Path {
            pieces,
            heading_integral: Vec::new(),
            length_m: s,
        };
        let mut unwrapped: Option<f64> = None;
        let mut g = 0.0;
        let mut prev: Option<(f64, f64, f64)> = None; // (start, theta0, rate)
        for k in 0..path.pieces.len() {
            let (s0, piece) = path.pieces[k];
            let raw = path.at(s0).heading_rad;
            let rate = match piece {
                Piece::Line { .. } => 0.0,
                Piece::Arc { radius_m, turn, .. } => turn / radius_m,
            };
            if let Some((p0, t0, r0)) = prev {
                let len = s0 - p0;
                g += t0 * len + 0.5 * r0 * len * len;
            }
            let theta0 = match unwrapped {
                None => raw,
                Some(u) => {
                    u + (raw - u + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                        - std::f64::consts::PI
                }
            };
            path.heading_integral.push((theta0, rate, g));
            prev = Some((s0, theta0, rate));
            let next_start = path.pieces.get(k + 1).map_or(s0, |p| p.0);
            unwrapped = Some(theta0 + rate * (next_start - s0));
        }
        Some(path)
    }

    /// Total length, metres.
    pub fn length_m(&self) -> f64 {
        self.length_m
    }

    /// Integral of the unwrapped tangent heading from 0 to `s_m` (straight extension outside).
    fn heading_integral_at(&self, s_m: f64) -> f64 {
        let k = self
            .pieces
            .partition_point(|(s0, _)| *s0 <= s_m)
            .saturating_sub(1);
        match (self.pieces.get(k), self.heading_integral.get(k)) {
            (Some(&(s0, _)), Some(&(theta0, rate, g))) => {
                let u = s_m - s0;
                g + theta0 * u + 0.5 * rate * u * u
            }
            _ => 0.0,
        }
    }

    /// The tangent heading averaged over [`HEADING_WINDOW_M`] around `s_m`, radians (unwrapped:
    /// continuous along the path, possibly outside −π..π). Differentiable in `s_m`.
    pub fn smooth_heading_rad(&self, s_m: f64) -> f64 {
        let h = 0.5 * HEADING_WINDOW_M;
        (self.heading_integral_at(s_m + h) - self.heading_integral_at(s_m - h)) / HEADING_WINDOW_M
    }

    /// The point at arc length `s_m`; beyond either end the first or last segment is extended
    /// in a straight line.
    pub fn at(&self, s_m: f64) -> PathPoint {
        let k = self
            .pieces
            .partition_point(|(s0, _)| *s0 <= s_m)
            .saturating_sub(1);
        let Some(&(s0, piece)) = self.pieces.get(k) else {
            return PathPoint {
                position_m: Vector2::zeros(),
                heading_rad: 0.0,
            };
        };
        let u = s_m - s0;
        match piece {
            Piece::Line { start, dir } => PathPoint {
                position_m: start + dir * u,
                heading_rad: heading(&dir),
            },
            Piece::Arc {
                center,
                radius_m,
                angle0_rad,
                turn,
            } => {
                let a = angle0_rad + turn * u / radius_m;
                PathPoint {
                    position_m: center + Vector2::new(a.cos(), a.sin()) * radius_m,
                    heading_rad: a + turn * std::f64::consts::FRAC_PI_2,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn l_shaped_path_is_continuous_and_turns_left_by_ninety_degrees() {
        let path = Path::new(&[[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]], 1.0).unwrap();
        // 3 + 2 straight plus a quarter circle of radius 1.
        assert_relative_eq!(
            path.length_m(),
            3.0 + 2.0 + std::f64::consts::FRAC_PI_2,
            epsilon = 1e-12
        );
        let mut prev = path.at(0.0);
        let n = 2000;
        for i in 1..=n {
            let p = path.at(path.length_m() * i as f64 / n as f64);
            let step = path.length_m() / n as f64;
            assert!((p.position_m - prev.position_m).norm() <= step * 1.000_001);
            let mut dh = p.heading_rad - prev.heading_rad;
            dh = (dh + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            assert!(dh.abs() <= step / 1.0 + 1e-9);
            prev = p;
        }
        assert_relative_eq!(prev.position_m, Vector2::new(4.0, 3.0), epsilon = 1e-9);
        assert_relative_eq!(
            prev.heading_rad,
            std::f64::consts::FRAC_PI_2,
            epsilon = 1e-9
        );
    }

    #[test]
    fn smooth_heading_equals_the_tangent_on_long_straights_and_turns_continuously() {
        let path = Path::new(&[[0.0, 0.0], [4.0, 0.0], [4.0, 3.0], [0.0, 3.0]], 0.6).unwrap();
        assert_relative_eq!(path.smooth_heading_rad(1.0), 0.0, epsilon = 1e-12);
        assert_relative_eq!(path.smooth_heading_rad(-2.0), 0.0, epsilon = 1e-12);
        let end = path.length_m();
        assert_relative_eq!(
            path.smooth_heading_rad(end - 1.0),
            std::f64::consts::PI,
            epsilon = 1e-9
        );
        assert_relative_eq!(
            path.smooth_heading_rad(end + 3.0),
            std::f64::consts::PI,
            epsilon = 1e-9
        );
        let mut prev = path.smooth_heading_rad(0.0);
        for i in 1..=4000 {
            let h = path.smooth_heading_rad(end * i as f64 / 4000.0);
            assert!((h - prev).abs() < 2e-3 * end / 0.6 + 1e-9);
            prev = h;
        }
    }

    #[test]
    fn corner_radius_shrinks_to_fit_short_segments() {
        let path = Path::new(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], 5.0).unwrap();
        let end = path.at(path.length_m());
        assert_relative_eq!(end.position_m, Vector2::new(1.0, 1.0), epsilon = 1e-9);
    }
}
