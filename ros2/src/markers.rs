//! RViz2 / Foxglove markers: a line strip per predicted sample (shaded by score when
//! scores are on), deletions for tracks that ended, and the map as arrows.

use cliff::map::CliffMap;

use crate::msg::{
    ColorRGBA, Duration, Header, Marker, MarkerArray, Point, Pose, Quaternion, Vector3,
};

/// Namespace of the prediction line strips.
pub const NS_PREDICTIONS: &str = "cliff_predictions";
/// Namespace of the map arrows.
pub const NS_MAP: &str = "cliff_map";

/// The marker id of sample `s` of the track numbered `number` (k samples per track).
pub fn sample_id(number: u32, k: usize, s: usize) -> i32 {
    number.wrapping_mul(k as u32).wrapping_add(s as u32) as i32
}

/// A colour per track: hues around the circle by the golden angle.
pub fn track_color(number: u32) -> ColorRGBA {
    let (r, g, b) = hsv(number as f64 * 0.618_033_988_75);
    // a little lighter than pure hues, readable on RViz's dark grey
    let l = |c: f32| 0.25 + 0.75 * c;
    ColorRGBA {
        r: l(r),
        g: l(g),
        b: l(b),
        a: 0.8,
    }
}

/// Opacity of each sample from its score (log-likelihood): the most likely opaque,
/// the others by `exp(score - best)`, never below 0.1. NaN scores get 0.1.
pub fn score_alphas(scores: &[f32], out: &mut Vec<f32>) {
    out.clear();
    let best = scores
        .iter()
        .copied()
        .filter(|s| s.is_finite())
        .fold(f32::NEG_INFINITY, f32::max);
    for &s in scores {
        let a = if s.is_finite() && best.is_finite() {
            (s - best).exp()
        } else {
            0.0
        };
        out.push(a.clamp(0.0, 1.0) * 0.9 + 0.1);
    }
}

/// Settings of the prediction markers.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerStyle {
    /// Line width (m).
    pub width: f64,
    /// Seconds a marker stays when not refreshed (0: until deleted).
    pub lifetime: f64,
    /// Height (z, m) of the lines.
    pub z: f64,
}

impl Default for MarkerStyle {
    fn default() -> Self {
        MarkerStyle {
            width: 0.03,
            lifetime: 1.0,
            z: 0.0,
        }
    }
}

fn duration(s: f64) -> Duration {
    let t = crate::msg::Time::from_secs_f64(s.max(0.0));
    Duration {
        sec: t.sec,
        nanosec: t.nanosec,
    }
}

/// Reset `m` to a default marker of the predictions in `header`, keeping the capacity
/// of its strings and lists (a reused marker allocates nothing once warmed up).
fn reset(m: &mut Marker, header: &Header) {
    m.header.stamp = header.stamp;
    m.header.frame_id.clone_from(&header.frame_id);
    m.ns.clear();
    m.ns.push_str(NS_PREDICTIONS);
    m.id = 0;
    m.type_ = Marker::ARROW;
    m.action = Marker::ADD;
    m.pose = Pose::default();
    m.scale = Vector3::default();
    m.color = ColorRGBA::default();
    m.lifetime = Duration::default();
    m.frame_locked = false;
    m.points.clear();
    m.colors.clear();
    m.texture_resource.clear();
    m.texture.header.stamp = Default::default();
    m.texture.header.frame_id.clear();
    m.texture.format.clear();
    m.texture.data.clear();
    m.uv_coordinates.clear();
    m.text.clear();
    m.mesh_resource.clear();
    m.mesh_file.filename.clear();
    m.mesh_file.data.clear();
    m.mesh_use_embedded_materials = false;
}

/// Make `m` the line strip of one sample: the origin, then the points.
pub fn fill_line_strip(
    m: &mut Marker,
    header: &Header,
    style: &MarkerStyle,
    id: i32,
    origin: [f32; 2],
    points: &[[f32; 2]],
    color: ColorRGBA,
) {
    reset(m, header);
    m.id = id;
    m.type_ = Marker::LINE_STRIP;
    m.scale.x = style.width;
    m.color = color;
    m.lifetime = duration(style.lifetime);
    let p = |q: [f32; 2]| Point {
        x: q[0] as f64,
        y: q[1] as f64,
        z: style.z,
    };
    m.points.push(p(origin));
    m.points.extend(points.iter().map(|&q| p(q)));
    if m.points.len() == 1 {
        // RViz wants two points for a line
        m.points.push(p(origin));
    }
}

/// A line strip of one sample: the origin, then the points.
pub fn line_strip(
    header: &Header,
    style: &MarkerStyle,
    id: i32,
    origin: [f32; 2],
    points: &[[f32; 2]],
    color: ColorRGBA,
) -> Marker {
    let mut m = Marker::default();
    fill_line_strip(&mut m, header, style, id, origin, points, color);
    m
}

/// Make `m` the deletion of marker `id` of the predictions.
pub fn fill_delete(m: &mut Marker, header: &Header, id: i32) {
    reset(m, header);
    m.id = id;
    m.action = Marker::DELETE;
}

/// A deletion of marker `id` of the predictions.
pub fn delete(header: &Header, id: i32) -> Marker {
    let mut m = Marker::default();
    fill_delete(&mut m, header, id);
    m
}

/// The map as arrows: one per component, from its location along its mean direction,
/// as long as `seconds` of its mean speed, as opaque as its weight.
pub fn map_arrows(map: &CliffMap, frame_id: &str, seconds: f64) -> MarkerArray {
    let header = Header {
        frame_id: frame_id.to_string(),
        ..Header::default()
    };
    let mut out = MarkerArray::default();
    out.markers.push(Marker {
        header: header.clone(),
        ns: NS_MAP.to_string(),
        action: Marker::DELETEALL,
        ..Marker::default()
    });
    let mut id = 0i32;
    for loc in map.locations() {
        for c in &loc.components {
            let hue = c.theta / std::f64::consts::TAU;
            let (r, g, b) = hsv(hue);
            out.markers.push(Marker {
                header: header.clone(),
                ns: NS_MAP.to_string(),
                id,
                type_: Marker::ARROW,
                action: Marker::ADD,
                pose: Pose {
                    position: Point {
                        x: loc.position.x,
                        y: loc.position.y,
                        z: 0.0,
                    },
                    orientation: Quaternion::from_yaw(c.theta),
                },
                scale: Vector3 {
                    x: (c.rho * seconds).max(0.02),
                    y: 0.04,
                    z: 0.04,
                },
                color: ColorRGBA {
                    r,
                    g,
                    b,
                    a: (0.2 + 0.8 * c.weight.clamp(0.0, 1.0)) as f32,
                },
                ..Marker::default()
            });
            id = id.wrapping_add(1);
        }
    }
    out
}

fn hsv(h: f64) -> (f32, f32, f32) {
    let h = h.rem_euclid(1.0) * 6.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    (r as f32, g as f32, b as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alphas_follow_the_scores() {
        let mut a = Vec::new();
        score_alphas(&[-1.0, -3.0, f32::NAN], &mut a);
        assert!((a[0] - 1.0).abs() < 1e-6);
        assert!(a[1] < a[0] && a[1] > 0.1);
        assert!((a[2] - 0.1).abs() < 1e-6);
    }

    #[test]
    fn ids_are_distinct_per_track_and_sample() {
        let mut seen = std::collections::HashSet::new();
        for n in 0..50 {
            for s in 0..20 {
                assert!(seen.insert(sample_id(n, 20, s)));
            }
        }
    }

    #[test]
    fn a_strip_starts_at_the_origin_and_has_two_points_at_least() {
        let h = Header::default();
        let m = line_strip(
            &h,
            &MarkerStyle::default(),
            3,
            [1.0, 2.0],
            &[],
            track_color(1),
        );
        assert_eq!(m.points.len(), 2);
        let m = line_strip(
            &h,
            &MarkerStyle::default(),
            3,
            [1.0, 2.0],
            &[[1.5, 2.0], [2.0, 2.0]],
            track_color(1),
        );
        assert_eq!(
            (m.points.len(), m.points[0].x, m.points[2].x),
            (3, 1.0, 2.0)
        );
        assert_eq!(m.type_, Marker::LINE_STRIP);
    }

    #[test]
    fn a_reused_marker_is_the_same_as_a_new_one() {
        let h = Header {
            frame_id: "map".into(),
            ..Header::default()
        };
        let style = MarkerStyle::default();
        let mut m = line_strip(&h, &style, 3, [1.0, 2.0], &[[1.5, 2.0]], track_color(1));
        m.text.push_str("left over");
        m.colors.push(ColorRGBA::default());
        fill_delete(&mut m, &h, 9);
        assert_eq!(m, delete(&h, 9));
        fill_line_strip(&mut m, &h, &style, 4, [0.0, 0.0], &[], track_color(2));
        assert_eq!(
            m,
            line_strip(&h, &style, 4, [0.0, 0.0], &[], track_color(2))
        );
    }

    #[test]
    fn the_demo_map_becomes_arrows_after_a_delete_all() {
        let map = CliffMap::demo();
        let n: usize = map.locations().iter().map(|l| l.components.len()).sum();
        let a = map_arrows(&map, "map", 1.0);
        assert_eq!(a.markers.len(), n + 1);
        assert_eq!(a.markers[0].action, Marker::DELETEALL);
        assert!(
            a.markers[1..]
                .iter()
                .all(|m| m.type_ == Marker::ARROW && m.header.frame_id == "map")
        );
    }
}
