//! The part of a density estimate's disc that lies on the surface: the boundary correction of
//! progressive photon mapping's fixed-radius estimates.
//!
//! An estimate divides the power of the photons within radius `r` of a point by `pi r^2`, the
//! area of the disc in the point's tangent plane. Where the surface ends within `r` (a concave
//! corner, where a wall meets the floor, or a convex edge, where a box's top meets its side),
//! part of that disc holds no surface and no photons, so the estimate is too dark there. The
//! error shrinks with the radius, but slowly: the region it affects is `r` wide, so it adds
//! `O(r^2)` to the image's squared error, which falls only as fast as the radius schedule lets
//! `r^2` fall (`i^(alpha - 1)` after `i` passes).
//!
//! The adjacent surface announces itself: its photons within the radius are the ones the
//! normal test rejects. Each such photon, at `x` with normal `m`, gives the plane of its surface;
//! that plane meets the tangent plane in a line at distance `h = |(p - x) . m| / sin(theta)`
//! from the query point `p` (`theta` the angle between the normals), and the surface holding
//! `p` lies on `p`'s side of it, for a concave corner (the far side is behind the other wall) as
//! for a convex edge (the far side is beyond the edge). [`Boundaries`] keeps the nearest such
//! line per direction, and [`Boundaries::area_fraction`] is the part of the disc on `p`'s side
//! of all of them. An estimate divides by that area instead of `pi r^2`.
//!
//! The correction changes estimates only where another surface comes within the radius of the
//! query, a region that vanishes as the radius shrinks, so the progressive render stays
//! consistent. A surface ending with no lit surface beside it (an open edge) gives no photons
//! to read its boundary from and keeps the dark band.

use glam::{Vec2, Vec3};

/// The most boundary lines kept per estimate: a room's corner has three surfaces meeting, so
/// two lines besides the query's own surface.
const MAX_LINES: usize = 3;
/// Lines whose directions are closer than this cosine are one line (the same plane read from
/// several of its photons, whose normals differ by their 32-bit encoding).
const SAME_LINE_COSINE: f32 = 0.99;
/// Distances (over the radius) below which a line runs through the query point.
const ON_LINE: f32 = 1e-3;
/// Photons of surfaces within this sine of parallel to the query's give no line: the back of a
/// thin sheet, or a parallel surface across a gap, does not bound the query's surface.
const MIN_SINE: f32 = 0.2;
/// Azimuths of the polar integration of a disc clipped by several lines.
const AZIMUTHS: usize = 64;
/// The smallest area fraction an estimate divides by: a query exactly on an edge keeps at
/// least this much of its disc (half of it for a straight edge, a quarter in a corner).
const MIN_FRACTION: f32 = 0.1;

/// A line in the query's tangent plane: the direction from the query point toward it, in the
/// plane's frame, its distance over the radius, and how far along it (over the radius, from
/// the foot of the perpendicular) the photons that gave it lie. A surface that ends (a box's
/// face at the box's corner) bounds the query's surface only along its own extent.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Line {
    toward: Vec2,
    distance: f32,
    span: [f32; 2],
}

impl Line {
    /// The coordinate along the line of a point `x` of the tangent plane's frame.
    #[inline]
    fn along(&self, x: Vec2) -> f32 {
        x.perp_dot(self.toward)
    }
}

/// Directions of the polar integration, at the midpoints of equal angles.
static AZIMUTH_DIRECTIONS: std::sync::LazyLock<[Vec2; AZIMUTHS]> = std::sync::LazyLock::new(|| {
    std::array::from_fn(|k| {
        let (sin, cos) = ((k as f32 + 0.5) * (std::f32::consts::TAU / AZIMUTHS as f32)).sin_cos();
        Vec2::new(cos, sin)
    })
});

/// The nearest boundary lines found among a query's rejected photons.
#[derive(Clone, Debug)]
pub struct Boundaries {
    p: Vec3,
    n: Vec3,
    tangent: Vec3,
    bitangent: Vec3,
    inv_r: f32,
    lines: [Line; MAX_LINES],
    len: usize,
}

impl Boundaries {
    /// No lines yet around `p`, on the surface of unit normal `n`, for radius `sqrt(r2)`.
    pub fn new(p: Vec3, n: Vec3, r2: f32) -> Boundaries {
        let (tangent, bitangent) = n.any_orthonormal_pair();
        let none = Line { toward: Vec2::ZERO, distance: 1.0, span: [0.0; 2] };
        Boundaries { p, n, tangent, bitangent, inv_r: 1.0 / r2.sqrt(), lines: [none; MAX_LINES], len: 0 }
    }

    /// Reads the boundary given by a photon within the radius at `x` on a surface of normal
    /// `m` that the normal test rejected.
    #[inline]
    pub fn add(&mut self, x: Vec3, m: Vec3) {
        // The part of `m` in the tangent plane points away from the other plane on the side
        // where `p` is in front of it, toward it where `p` is behind it.
        let in_plane = m - m.dot(self.n) * self.n;
        let sine = in_plane.length();
        if !(sine > MIN_SINE) {
            return;
        }
        let s = (self.p - x).dot(m);
        let distance = s.abs() / sine * self.inv_r;
        if !(distance < 1.0) {
            return;
        }
        let dir = in_plane * (-s.signum() / sine);
        let toward = Vec2::new(dir.dot(self.tangent), dir.dot(self.bitangent));
        let offset = x - self.p;
        let at = Vec2::new(offset.dot(self.tangent), offset.dot(self.bitangent)) * self.inv_r;
        let kept = &mut self.lines[..self.len];
        // A query on the line itself (within the roundings of the photons' normals) sees it on
        // either side: opposite directions at about no distance are one line too.
        let same_line = |l: &Line| {
            let c = l.toward.dot(toward);
            c > SAME_LINE_COSINE || (c < -SAME_LINE_COSINE && l.distance + distance < ON_LINE)
        };
        if let Some(same) = kept.iter_mut().find(|l| same_line(l)) {
            let t = same.along(at);
            same.span = [same.span[0].min(t), same.span[1].max(t)];
            if distance < same.distance {
                // An opposite direction keeps the line's own, which its span is measured along.
                if same.toward.dot(toward) > 0.0 {
                    same.toward = toward;
                }
                same.distance = distance;
            }
            return;
        }
        let mut line = Line { toward, distance, span: [0.0; 2] };
        let t = line.along(at);
        line.span = [t, t];
        if self.len < MAX_LINES {
            self.lines[self.len] = line;
            self.len += 1;
        } else if let Some(farthest) = kept.iter_mut().max_by(|a, b| a.distance.total_cmp(&b.distance))
            && distance < farthest.distance
        {
            *farthest = line;
        }
    }

    /// The part of the disc that a ray from the query point reaches before crossing a line
    /// within the line's span, by polar integration: 1 with no line, the disc less a circular
    /// segment for a wall along the whole chord, less a quadrant's part for a box's corner.
    pub fn area_fraction(&self) -> f32 {
        if self.len == 0 {
            return 1.0;
        }
        let lines = &self.lines[..self.len];
        let mut sum = 0.0f32;
        for &d in AZIMUTH_DIRECTIONS.iter() {
            let mut reach = 1.0f32;
            for l in lines {
                let c = d.dot(l.toward);
                if c * reach > l.distance {
                    let hit = l.distance / c;
                    let t = l.along(d * hit);
                    if t >= l.span[0] && t <= l.span[1] {
                        reach = hit;
                    }
                }
            }
            sum += reach * reach;
        }
        (sum / AZIMUTHS as f32).max(MIN_FRACTION)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// The part of the unit disc around the origin of the floor (`z = 0`, normal `+z`) with
    /// `inside(x, y)`, by uniform samples.
    fn monte_carlo(inside: impl Fn(f32, f32) -> bool) -> f32 {
        let mut rng = Rng::new(7, 1);
        let (mut hit, mut all) = (0u32, 0u32);
        while all < 400_000 {
            let (x, y) = (rng.uniform() * 2.0 - 1.0, rng.uniform() * 2.0 - 1.0);
            if x * x + y * y < 1.0 {
                all += 1;
                hit += u32::from(inside(x, y));
            }
        }
        hit as f32 / all as f32
    }

    /// Photons every 0.02 along a segment of a surface of normal `m` (at height `z`, which
    /// the cut does not depend on).
    fn photons_along(b: &mut Boundaries, from: Vec3, to: Vec3, m: Vec3) {
        let n = ((to - from).length() / 0.02) as usize;
        for i in 0..=n {
            let mut x = from.lerp(to, i as f32 / n as f32);
            x.z = 0.05 + 0.4 * (i % 3) as f32;
            b.add(x, m);
        }
    }

    fn assert_near(b: &Boundaries, expected: f32, what: &str) {
        let got = b.area_fraction();
        assert!((got - expected).abs() < 0.01, "{what}: {got} vs {expected}");
    }

    /// A wall (normal `-x`) at `x = 0.3` in front of the query (a concave corner) and a box
    /// side (normal `+x`) at `x = 0.3` (a convex edge, the query on the box's top) cut the disc
    /// at the same line: both keep the part with `x < 0.3`.
    #[test]
    fn one_wall_or_edge_cuts_a_segment() {
        let expected = monte_carlo(|x, _| x < 0.3);
        for m in [-Vec3::X, Vec3::X] {
            let mut b = Boundaries::new(Vec3::ZERO, Vec3::Z, 1.0);
            photons_along(&mut b, Vec3::new(0.3, -1.0, 0.0), Vec3::new(0.3, 1.0, 0.0), m);
            assert_eq!(b.len, 1, "{m}");
            assert_near(&b, expected, &format!("{m}"));
        }
    }

    /// A slanted wall meets the floor's plane farther away than its distance from the query.
    #[test]
    fn slanted_wall_cuts_where_it_meets_the_plane() {
        let m = Vec3::new(-1.0, 0.0, 1.0).normalize();
        // The plane through (0.5, 0, 0) with that normal meets z = 0 at x = 0.5; its photons
        // at height z sit at x = 0.5 + z.
        let mut b = Boundaries::new(Vec3::ZERO, Vec3::Z, 1.0);
        for i in 0..=100 {
            let z = 0.1 * (i % 3) as f32;
            b.add(Vec3::new(0.5 + z, -1.0 + 0.02 * i as f32, z), m);
        }
        assert_near(&b, monte_carlo(|x, _| x < 0.5), "slanted");
    }

    /// In a room's corner two walls cut the disc, each where it stands.
    #[test]
    fn corner_of_two_walls() {
        let mut b = Boundaries::new(Vec3::ZERO, Vec3::Z, 4.0);
        // Radius 2: the walls at 0.4 and 0.3 radii, meeting at (0.8, -0.6).
        photons_along(&mut b, Vec3::new(0.8, -0.6, 0.0), Vec3::new(0.8, 2.0, 0.0), -Vec3::X);
        photons_along(&mut b, Vec3::new(-2.0, -0.6, 0.0), Vec3::new(0.8, -0.6, 0.0), Vec3::Y);
        assert_eq!(b.len, 2);
        assert_near(&b, monte_carlo(|x, y| x < 0.4 && y > -0.3), "room corner");
    }

    /// Beside a box's corner the floor goes on: the box's two faces cut only the box's own
    /// footprint, not the half-planes beyond their planes.
    #[test]
    fn box_corner_cuts_its_footprint_only() {
        let mut b = Boundaries::new(Vec3::ZERO, Vec3::Z, 1.0);
        photons_along(&mut b, Vec3::new(0.3, 0.3, 0.0), Vec3::new(0.3, 1.0, 0.0), -Vec3::X);
        photons_along(&mut b, Vec3::new(0.3, 0.3, 0.0), Vec3::new(1.0, 0.3, 0.0), -Vec3::Y);
        assert_near(&b, monte_carlo(|x, y| !(x > 0.3 && y > 0.3)), "box corner");
    }

    /// Surfaces that do not bound the query's give no line: a far wall, a thin sheet's back,
    /// a parallel surface.
    #[test]
    fn far_and_parallel_surfaces_leave_the_disc_whole() {
        let mut b = Boundaries::new(Vec3::ZERO, Vec3::Z, 1.0);
        b.add(Vec3::new(1.2, 0.0, 0.5), -Vec3::X);
        b.add(Vec3::new(0.1, 0.1, -0.001), -Vec3::Z);
        b.add(Vec3::new(0.1, 0.1, 0.3), -Vec3::Z);
        b.add(Vec3::new(0.1, 0.1, 0.3), Vec3::new(0.1, 0.0, -1.0).normalize());
        assert_eq!(b.area_fraction(), 1.0);
    }

    /// A query on the edge itself keeps half its disc, also when the photons' normals, rounded
    /// by their encoding, put the line a hair to either side of it.
    #[test]
    fn query_on_the_edge_keeps_half() {
        let mut b = Boundaries::new(Vec3::ZERO, Vec3::Z, 1.0);
        for (i, tilt) in [0.0, 1e-6, -1e-6].into_iter().enumerate() {
            let m = Vec3::new(-1.0, 0.0, tilt).normalize();
            photons_along(&mut b, Vec3::new(0.0, -1.0 + 0.01 * i as f32, 0.0), Vec3::new(0.0, 1.0, 0.0), m);
        }
        assert_eq!(b.len, 1);
        assert_near(&b, 0.5, "on the edge");
    }
}
