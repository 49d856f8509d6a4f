//! Radio propagation geometry of a box room by the image method.
//!
//! The room is the axis-aligned box [0, size_x] × [0, size_y] × [0, size_z] in the world frame
//! `w` (z up, floor at z = 0). Its six faces are ideal specular mirrors with a real amplitude
//! reflection coefficient Γ. A path that reflects off planes P₁, then P₂, … has the same length
//! as the straight line from the receiver to the *image* of the transmitter, Pₙ(…P₁(tx)), and
//! arrives from that image's direction.
//!
//! ## Which images exist (counts per order)
//!
//! - Order 0: the direct path, 1.
//! - Order 1: one mirror per face, 6.
//! - Order 2: mirror compositions over two *distinct* planes (a plane twice is the identity), so
//!   at most 6·5 = 30 ordered pairs:
//!   - the two opposite planes of one axis do not commute: x → −x → 2L + x (near plane first)
//!     and x → 2L − x → x − 2L (far plane first) are different images, both valid: 3 axes × 2
//!     orders = **6**;
//!   - planes of two different axes act on different coordinates, so they commute and both orders
//!     give the same *corner image*. Only one order is physical: the unfolded line from the
//!     receiver crosses one of the two planes first, and that one must be the *last* reflection
//!     (the other order puts a reflection point off its finite face). 3 axis pairs × 2 × 2 planes
//!     = **12** images, one path each (24 ordered pairs → 12).
//!
//!   Total second order: 6 + 12 = **18** paths, so `max_order = 2` gives 1 + 6 + 18 = 25.
//!
//! Every reflection point is computed (walking the unfolded line back from the receiver, one
//! mirror at a time) and a path is kept only if each point lies on its finite face; for a
//! transmitter and a receiver inside the box this always holds for the paths above (tested).
//! The same walk gives the real segments that are tested against the obstacle.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::sim::ConfigError;

/// How far (m) a reflection point may lie outside its finite face and still count as on it,
/// to absorb rounding when the path passes through an edge or a corner of the room.
const FACE_TOLERANCE_M: f64 = 1e-9;

/// Most paths `paths_into` can produce (orders 0, 1 and 2): 1 + 6 + 18.
const MAX_PATHS: usize = 25;

/// The room: an axis-aligned box with reflecting walls, floor and ceiling.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RoomConfig {
    /// Inner size (x, y, z), metres; the room spans [0, size] on each axis. Default [12, 8, 4],
    /// the paper's test site; wrong for any other building.
    pub size_m: [f64; 3],
    /// Amplitude reflection coefficient of the four walls (x and y faces); real, |Γ| < 1,
    /// negative = phase flip. Default 0.4: plasterboard and concrete at 5 GHz have
    /// |Γ| ≈ 0.3–0.6, and a typical indoor Rician K of a few dB follows. Wrong for metal walls
    /// (|Γ| → 1) or glass.
    pub wall_reflection: f64,
    /// Amplitude reflection coefficient of the floor (z = 0), same conventions. Default 0.5.
    pub floor_reflection: f64,
    /// Amplitude reflection coefficient of the ceiling (z = size_z), same conventions.
    /// Default 0.4.
    pub ceiling_reflection: f64,
    /// Highest reflection order of the image method: 0 (direct path only), 1 (adds the six
    /// first-order images) or 2 (adds the 18 second-order images). Default 1.
    pub max_order: u8,
}

impl Default for RoomConfig {
    fn default() -> Self {
        Self {
            size_m: [12.0, 8.0, 4.0],
            wall_reflection: 0.4,
            floor_reflection: 0.5,
            ceiling_reflection: 0.4,
            max_order: 1,
        }
    }
}

impl RoomConfig {
    /// Checks the values; `field` is this config's dotted path, used in the error
    /// (e.g. `room` gives `room.size_m`).
    pub fn validate(&self, field: &str) -> Result<(), ConfigError> {
        if self.size_m.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(ConfigError::new(
                format!("{field}.size_m"),
                format!("every size must be finite and > 0 m, got {:?}", self.size_m),
            ));
        }
        for (name, gamma) in [
            ("wall_reflection", self.wall_reflection),
            ("floor_reflection", self.floor_reflection),
            ("ceiling_reflection", self.ceiling_reflection),
        ] {
            if !(gamma.is_finite() && gamma.abs() <= 1.0) {
                return Err(ConfigError::new(
                    format!("{field}.{name}"),
                    format!("a reflection coefficient must satisfy |Γ| ≤ 1, got {gamma}"),
                ));
            }
        }
        if self.max_order > 2 {
            return Err(ConfigError::new(
                format!("{field}.max_order"),
                format!(
                    "the image method is implemented up to order 2, got {}",
                    self.max_order
                ),
            ));
        }
        Ok(())
    }

    /// Whether `p` (world frame, m) lies strictly inside the room (not on a face).
    pub fn contains(&self, p: &Vector3<f64>) -> bool {
        (0..3).all(|k| p[k] > 0.0 && p[k] < self.size_m[k])
    }

    /// The six mirror planes, in the order x = 0, x = size_x, y = 0, y = size_y, floor, ceiling.
    fn planes(&self) -> [Plane; 6] {
        let [sx, sy, sz] = self.size_m;
        let (wall, floor, ceiling) = (
            self.wall_reflection,
            self.floor_reflection,
            self.ceiling_reflection,
        );
        [
            Plane::new(0, 0.0, wall),
            Plane::new(0, sx, wall),
            Plane::new(1, 0.0, wall),
            Plane::new(1, sy, wall),
            Plane::new(2, 0.0, floor),
            Plane::new(2, sz, ceiling),
        ]
    }
}

/// A box that attenuates every path segment passing through it (the paper's board in front of
/// the AP).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleConfig {
    /// Lower corner (x, y, z) in the world frame, m.
    pub min_m: [f64; 3],
    /// Upper corner (x, y, z) in the world frame, m; ≥ `min_m` on each axis (equal = a thin
    /// sheet).
    pub max_m: [f64; 3],
    /// Power attenuation per crossing, dB (≥ 0).
    pub attenuation_db: f64,
}

impl ObstacleConfig {
    /// Checks the values; `field` is this config's dotted path, used in the error
    /// (e.g. `obstacle` gives `obstacle.max_m`).
    pub fn validate(&self, field: &str) -> Result<(), ConfigError> {
        if self.min_m.iter().any(|v| !v.is_finite()) {
            return Err(ConfigError::new(
                format!("{field}.min_m"),
                format!("must be finite, got {:?}", self.min_m),
            ));
        }
        if self.max_m.iter().any(|v| !v.is_finite()) {
            return Err(ConfigError::new(
                format!("{field}.max_m"),
                format!("must be finite, got {:?}", self.max_m),
            ));
        }
        if (0..3).any(|k| self.max_m[k] < self.min_m[k]) {
            return Err(ConfigError::new(
                format!("{field}.max_m"),
                format!(
                    "must be ≥ min_m on every axis, got max {:?} < min {:?}",
                    self.max_m, self.min_m
                ),
            ));
        }
        if !(self.attenuation_db.is_finite() && self.attenuation_db >= 0.0) {
            return Err(ConfigError::new(
                format!("{field}.attenuation_db"),
                format!("must be finite and ≥ 0 dB, got {}", self.attenuation_db),
            ));
        }
        Ok(())
    }

    /// Slab test: does the closed segment a→b intersect the closed box?
    ///
    /// Both are closed: a segment that only touches a face, an edge or a corner, or that runs
    /// along a face, counts as crossing (a path grazing the board is attenuated). A segment
    /// parallel to a face crosses only if it lies within that face's slab (bounds inclusive).
    /// A zero-length segment is a point-in-box test.
    pub fn blocks_segment(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> bool {
        let (mut t_enter, mut t_exit) = (0.0_f64, 1.0_f64);
        for k in 0..3 {
            let (lo, hi) = (self.min_m[k], self.max_m[k]);
            let d = b[k] - a[k];
            if d == 0.0 {
                if a[k] < lo || a[k] > hi {
                    return false;
                }
                continue;
            }
            // Division (not multiplication by 1/d) keeps 0/d = 0 when a lies on a slab bound.
            let (t_lo, t_hi) = ((lo - a[k]) / d, (hi - a[k]) / d);
            let (t_near, t_far) = if t_lo <= t_hi {
                (t_lo, t_hi)
            } else {
                (t_hi, t_lo)
            };
            t_enter = t_enter.max(t_near);
            t_exit = t_exit.min(t_far);
            if t_enter > t_exit {
                return false;
            }
        }
        true
    }

    /// Amplitude factor of one crossing, 10^(−dB/20).
    fn amplitude_factor(&self) -> f64 {
        10f64.powf(-self.attenuation_db / 20.0)
    }
}

/// One propagation path from a transmitter to a receiver point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Path {
    /// Unfolded length (= distance from the image source to the receiver), m.
    pub length_m: f64,
    /// Unit vector at the receiver pointing toward where the path arrives from (toward the
    /// image source), world frame. Zero only for a direct path of zero length.
    pub toward_source_in_w: Vector3<f64>,
    /// Amplitude factor excluding free-space spreading: product of the reflection coefficients
    /// and of each obstacle's amplitude factor 10^(−dB/20) for each segment that crosses it.
    pub gain: f64,
    /// Number of reflections (0 = direct path).
    pub order: u8,
    /// Whether any segment of this path crosses an obstacle.
    pub obstructed: bool,
}

/// One mirror plane of the room: `p[axis] = coord`.
#[derive(Clone, Copy, Debug)]
struct Plane {
    axis: usize,
    coord: f64,
    reflection: f64,
}

impl Plane {
    const fn new(axis: usize, coord: f64, reflection: f64) -> Self {
        Self {
            axis,
            coord,
            reflection,
        }
    }

    /// Mirror image of `p` through this plane.
    fn mirror(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let mut q = *p;
        q[self.axis] = 2.0 * self.coord - q[self.axis];
        q
    }
}

/// Whether `r` (on the plane's infinite extension) lies on the room's finite face.
fn on_face(room: &RoomConfig, plane: &Plane, r: &Vector3<f64>) -> bool {
    (0..3)
        .filter(|&k| k != plane.axis)
        .all(|k| r[k] >= -FACE_TOLERANCE_M && r[k] <= room.size_m[k] + FACE_TOLERANCE_M)
}

/// Amplitude factor of the obstacles a segment a→b crosses (1 when none), and whether any.
fn crossing(obstacles: &[ObstacleConfig], a: &Vector3<f64>, b: &Vector3<f64>) -> (f64, bool) {
    obstacles
        .iter()
        .filter(|o| o.blocks_segment(a, b))
        .fold((1.0, false), |(g, _), o| (g * o.amplitude_factor(), true))
}

/// Walks the path that reflects off `mirrors` (in the order the wave meets them, starting at
/// the transmitter) back from the receiver to the transmitter, one reflection at a time.
///
/// `image` is the transmitter mirrored through all of `mirrors` in order. Returns the product of
/// the amplitude factors of every obstacle crossed by every real segment and whether any was
/// crossed, or `None` if a reflection point misses its finite face (the mirror sequence is not
/// a physical path).
fn trace(
    room: &RoomConfig,
    obstacles: &[ObstacleConfig],
    p_tx_in_w: &Vector3<f64>,
    p_rx_in_w: &Vector3<f64>,
    mirrors: &[Plane],
    image: &Vector3<f64>,
) -> Option<(f64, bool)> {
    let mut gain = 1.0;
    let mut obstructed = false;
    let mut start = *p_rx_in_w;
    let mut image = *image;
    for plane in mirrors.iter().rev() {
        let d = image - start;
        let along = d[plane.axis];
        if along == 0.0 {
            return None;
        }
        let t = (plane.coord - start[plane.axis]) / along;
        if !(0.0..=1.0).contains(&t) {
            return None;
        }
        let mut reflection_point = start + d * t;
        reflection_point[plane.axis] = plane.coord;
        if !on_face(room, plane, &reflection_point) {
            return None;
        }
        let (g, crossed) = crossing(obstacles, &start, &reflection_point);
        gain *= g;
        obstructed |= crossed;
        start = reflection_point;
        image = plane.mirror(&image);
    }
    let (g, crossed) = crossing(obstacles, &start, p_tx_in_w);
    Some((gain * g, obstructed || crossed))
}

/// Shared per-call state of [`paths_into`].
struct Tracer<'a> {
    room: &'a RoomConfig,
    obstacles: &'a [ObstacleConfig],
    p_tx_in_w: &'a Vector3<f64>,
    p_rx_in_w: &'a Vector3<f64>,
}

impl Tracer<'_> {
    /// The path reflecting off `mirrors` (order met by the wave), if it is physical.
    fn path(&self, mirrors: &[Plane], image: &Vector3<f64>) -> Option<Path> {
        let (crossing_gain, obstructed) = trace(
            self.room,
            self.obstacles,
            self.p_tx_in_w,
            self.p_rx_in_w,
            mirrors,
            image,
        )?;
        let reflection: f64 = mirrors.iter().map(|p| p.reflection).product();
        Some(self.make_path(
            image,
            reflection * crossing_gain,
            obstructed,
            mirrors.len() as u8,
        ))
    }

    fn make_path(&self, image: &Vector3<f64>, gain: f64, obstructed: bool, order: u8) -> Path {
        let to_image = image - self.p_rx_in_w;
        let length_m = to_image.norm();
        let toward_source_in_w = if length_m > 0.0 {
            to_image / length_m
        } else {
            Vector3::zeros()
        };
        Path {
            length_m,
            toward_source_in_w,
            gain,
            order,
            obstructed,
        }
    }
}

/// All paths from `p_tx_in_w` to `p_rx_in_w` up to `room.max_order`, written into `out`.
///
/// `out` is cleared first so the caller can reuse its allocation across calls (this runs tens of
/// thousands of times per simulation); nothing else is allocated. Order of the output: the
/// direct path first (always present), then the first-order paths (faces x = 0, x = size_x,
/// y = 0, y = size_y, floor, ceiling), then the second-order paths (see the module doc: 18 for
/// points inside the box).
///
/// Both points are expected strictly inside the room ([`RoomConfig::contains`]); reflected paths
/// whose reflection points miss their finite faces are dropped. If the two points coincide the
/// direct path has length 0 and a zero direction.
pub fn paths_into(
    room: &RoomConfig,
    obstacles: &[ObstacleConfig],
    p_tx_in_w: &Vector3<f64>,
    p_rx_in_w: &Vector3<f64>,
    out: &mut Vec<Path>,
) {
    out.clear();
    out.reserve(MAX_PATHS);
    let tracer = Tracer {
        room,
        obstacles,
        p_tx_in_w,
        p_rx_in_w,
    };
    let (direct_gain, direct_obstructed) = crossing(obstacles, p_rx_in_w, p_tx_in_w);
    out.push(tracer.make_path(p_tx_in_w, direct_gain, direct_obstructed, 0));
    if room.max_order == 0 {
        return;
    }
    let planes = room.planes();
    for plane in &planes {
        let image = plane.mirror(p_tx_in_w);
        out.extend(tracer.path(&[*plane], &image));
    }
    if room.max_order == 1 {
        return;
    }
    for (i, first) in planes.iter().enumerate() {
        for second in &planes[i + 1..] {
            let forward = [*first, *second];
            let image = second.mirror(&first.mirror(p_tx_in_w));
            if first.axis == second.axis {
                // Opposite faces: the two orders give two different images, both physical.
                out.extend(tracer.path(&forward, &image));
                let backward = [*second, *first];
                let image = first.mirror(&second.mirror(p_tx_in_w));
                out.extend(tracer.path(&backward, &image));
            } else {
                // Different axes: one corner image; only one order has both reflection points
                // on their faces (at a tie through the room's edge, keep the first).
                let path = tracer
                    .path(&forward, &image)
                    .or_else(|| tracer.path(&[*second, *first], &image));
                out.extend(path);
            }
        }
    }
}

#[cfg(test)]
mod tests;
