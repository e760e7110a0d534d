//! The built-in synthetic scene, constructed in code so a fresh machine needs no data.
//!
//! A hall of 30 m x 20 m (x in [-15, 15], y in [-10, 10]) on a 1 m grid. An east-west
//! corridor (|y| <= 3) carries people walking east and west; a north-south corridor
//! (|x| <= 3) carries people walking north and south; where they cross, all four
//! directions mix. Outside the corridors nobody was seen, so the map has no locations
//! there and CLiFF-LHMP samples stop at the corridor walls.

use std::f64::consts::{FRAC_PI_2, PI};

use glam::DVec2;

use super::{CliffMap, Component, Location};

/// Half-width of each corridor (m).
pub const CORRIDOR_HALF_WIDTH: f64 = 3.0;

fn component(theta: f64, rho: f64, weight: f64) -> Component {
    Component {
        theta,
        rho,
        cov: [0.02, 0.005, 0.005, 0.04],
        weight,
    }
}

fn demo_map() -> CliffMap {
    let mut locations = Vec::new();
    for iy in -10..=10 {
        for ix in -15..=15 {
            let (x, y) = (ix as f64, iy as f64);
            let in_ew = y.abs() <= CORRIDOR_HALF_WIDTH;
            let in_ns = x.abs() <= CORRIDOR_HALF_WIDTH;
            let mut components = Vec::new();
            if in_ew {
                // Eastbound traffic keeps right (south side), westbound the north side.
                let east = 0.5 - 0.1 * (y / CORRIDOR_HALF_WIDTH);
                components.push(component(0.0, 1.3, east));
                components.push(component(PI, 1.2, 1.0 - east));
            }
            if in_ns {
                let north = 0.5 + 0.1 * (x / CORRIDOR_HALF_WIDTH);
                components.push(component(FRAC_PI_2, 1.1, north));
                components.push(component(3.0 * FRAC_PI_2, 1.0, 1.0 - north));
            }
            if components.is_empty() {
                continue;
            }
            let total: f64 = components.iter().map(|c| c.weight).sum();
            for c in &mut components {
                c.weight /= total;
            }
            // Busiest in the crossing and along the corridor centre lines.
            let d = y.abs().min(x.abs());
            let observation_ratio = if in_ew && in_ns {
                1.0
            } else {
                0.8 * (-d * d / 8.0).exp() + 0.1
            };
            locations.push(Location {
                position: DVec2::new(x, y),
                components,
                motion_ratio: 1.0,
                observation_ratio,
            });
        }
    }
    CliffMap::with_grid_step(locations, Some(1.0)).expect("the demo scene is a valid map")
}

impl CliffMap {
    /// The built-in synthetic scene: a 30 m x 20 m hall with two crossing pedestrian
    /// flows (east-west along the hall, north-south across it) and a mixed crossing.
    pub fn demo() -> Self {
        demo_map()
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;
    use crate::tracks::scene::{SceneOptions, demo_tracks};

    /// The synthetic people of the demo scene walk where the demo map has flow.
    #[test]
    fn people_walk_in_the_corridors_and_some_turn() {
        let opts = SceneOptions {
            people: 200,
            ..SceneOptions::default()
        };
        let tracks = demo_tracks(&opts);
        let map = CliffMap::demo();
        let mut turned = 0;
        for t in &tracks {
            assert!(
                t.rows.len() >= 15,
                "person {} has {} rows",
                t.id,
                t.rows.len()
            );
            for r in &t.rows {
                // inside a corridor (half width 3 m, plus the walkers' wobble)
                assert!(
                    r.position.x.abs() < 3.5 || r.position.y.abs() < 3.5,
                    "person {} off the corridors at {}",
                    t.id,
                    r.position
                );
                // the map has a location near every row
                assert!(map.nearest(r.position, 1.0).is_some());
                assert!(r.speed > 0.3 && r.speed < 2.3);
                assert!(r.angle > -PI && r.angle <= PI);
            }
            let a = t.rows[1].angle;
            let b = t.rows[t.rows.len() - 1].angle;
            if crate::math::wrap_pi(b - a).abs() > 1.0 {
                turned += 1;
            }
            // times increase by dt
            assert!(
                t.rows
                    .windows(2)
                    .all(|w| (w[1].t - w[0].t - 0.4).abs() < 1e-9)
            );
        }
        let share = turned as f64 / tracks.len() as f64;
        assert!((0.2..0.5).contains(&share), "turning share {share}");
    }
}
