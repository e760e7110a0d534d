//! The predicted people as a `nav_msgs/OccupancyGrid` (`cliff/occupancy`) for Nav2's
//! costmaps: a fixed grid in the map frame (`grid_origin`, `grid_size`,
//! `grid_resolution`), each cell the chance, in percent (0..100), that someone is in it
//! during the time window `[grid_from, grid_to]` seconds after the prediction's start,
//! relative to a person known to stand on the cell.
//!
//! The core library's `Occupancy::window` gives the chance that anyone is in the cell at
//! some time of the window (each person's samples from the last observed position on,
//! kernel-smoothed, people independent: `cliff::occupancy`). With `grid_decay` > 0 the
//! window is cut into steps of the prediction's `dt`, and a cell holds the largest over
//! the steps `[t_j, t_j + dt]` of the step's chance times
//! `exp(-(t_j - grid_from) / grid_decay)`: near-future passes count fully, later ones
//! less, as a planner trusts them less.
//!
//! A cell's chance is the probability mass of the people's kernels in it, which
//! shrinks with the cell (a 0.1 m cell under a person of 0.3 m holds about 2 % of the
//! person). The grid divides it by the mass of the cell centred under one person known
//! to be there ([`peak_mass`]), caps it at 1 and writes it in percent: 100 is a cell as
//! occupied as the one under a standing person, whatever the resolution.
//!
//! The buffers are reused: a steady cycle allocates nothing here.

use cliff::occupancy::{
    GridSpec, Occupancy, OccupancyError, Samples as OccSamples, Settings, normal_cdf,
};

use crate::msg::{Header, OccupancyGrid, Point, Pose, Quaternion};
use crate::predictor::Samples;

/// What the grid covers and how it weighs time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSettings {
    /// The corner of cell (0, 0), smallest x and y, in the map frame (m).
    pub origin: [f64; 2],
    /// Width and height (m); the cells are rounded up to cover them.
    pub size: [f64; 2],
    /// The side of a cell (m).
    pub resolution: f64,
    /// The window's start, seconds after the prediction's start (the last observation).
    pub from: f64,
    /// The window's end (at most the horizon).
    pub to: f64,
    /// Seconds over which a later step's chance decays (0: none).
    pub decay: f64,
}

impl Default for GridSettings {
    fn default() -> Self {
        GridSettings {
            origin: [-10.0, -10.0],
            size: [20.0, 20.0],
            resolution: 0.25,
            from: 0.0,
            to: 1.6,
            decay: 0.0,
        }
    }
}

impl GridSettings {
    /// The grid's cells.
    pub fn spec(&self) -> GridSpec {
        GridSpec::covering(
            self.origin,
            [self.origin[0] + self.size[0], self.origin[1] + self.size[1]],
            self.resolution,
        )
    }

    /// Reject a grid or window no cycle could use (`horizon`: the prediction's).
    pub fn check(&self, horizon: f64) -> Result<(), String> {
        if !(self.resolution.is_finite() && self.resolution > 0.0) {
            return Err(format!(
                "grid_resolution must be a positive number, not {}",
                self.resolution
            ));
        }
        if !(self.size.iter().all(|s| s.is_finite() && *s > 0.0)) {
            return Err(format!(
                "grid_size must be two positive numbers, not {:?}",
                self.size
            ));
        }
        self.spec().validate().map_err(|e| e.to_string())?;
        if !(self.from.is_finite()
            && self.to.is_finite()
            && 0.0 <= self.from
            && self.from < self.to)
        {
            return Err(format!(
                "grid_from and grid_to must satisfy 0 <= grid_from < grid_to, not {} and {}",
                self.from, self.to
            ));
        }
        if self.to > horizon + 1e-9 {
            return Err(format!(
                "grid_to {} is beyond the horizon {horizon}",
                self.to
            ));
        }
        if !(self.decay.is_finite() && self.decay >= 0.0) {
            return Err(format!(
                "grid_decay must be 0 (no decay) or positive, not {}",
                self.decay
            ));
        }
        Ok(())
    }
}

/// Builds the grid message of a cycle into reused buffers.
#[derive(Debug)]
pub struct GridBuilder {
    settings: GridSettings,
    spec: GridSpec,
    kernel: Settings,
    occupancy: Occupancy,
    cells: Vec<f32>,
    starts: Vec<[f32; 2]>,
    peak: f32,
}

/// The probability mass of a cell of side `resolution` centred under a person of
/// standard deviation `sigma` (m): the most any one person puts in a cell.
pub fn peak_mass(resolution: f64, sigma: f64) -> f64 {
    let side = 2.0 * normal_cdf(resolution / (2.0 * sigma)) - 1.0;
    side * side
}

impl GridBuilder {
    /// A builder of `settings` (checked by [`GridSettings::check`] first).
    pub fn new(settings: GridSettings) -> Self {
        let kernel = Settings::default();
        GridBuilder {
            spec: settings.spec(),
            peak: peak_mass(settings.resolution, kernel.person_radius) as f32,
            settings,
            kernel,
            occupancy: Occupancy::new(),
            cells: Vec::new(),
            starts: Vec::new(),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &GridSettings {
        &self.settings
    }

    /// The grid's cells.
    pub fn spec(&self) -> &GridSpec {
        &self.spec
    }

    /// Fill `msg` from `samples` (predicted `dt` apart, agent `a` last observed at
    /// `starts[a]`) with `header`'s stamp and frame.
    pub fn fill(
        &mut self,
        msg: &mut OccupancyGrid,
        header: &Header,
        samples: &Samples,
        starts: impl Iterator<Item = [f32; 2]>,
        dt: f64,
    ) -> Result<(), OccupancyError> {
        let spec = self.spec;
        let n = spec.cells();
        self.cells.clear();
        self.cells.resize(n, 0.0);
        self.starts.clear();
        self.starts.extend(starts);
        if samples.agents > 0 {
            let view = OccSamples::new(
                &samples.positions,
                &samples.lens,
                (samples.agents, samples.k, samples.steps),
                dt,
            )?
            .with_starts(&self.starts)?;
            let (from, to) = (self.settings.from, self.settings.to.min(view.span().1));
            // no decay: the window at once; decay: one window per step
            let steps = if self.settings.decay > 0.0 {
                (((to - from) / dt) - 1e-9).ceil().max(1.0) as usize
            } else {
                1
            };
            let len = (to - from) / steps as f64;
            for j in 0..steps {
                let t0 = from + j as f64 * len;
                let t1 = if j + 1 == steps { to } else { t0 + len };
                self.occupancy.window(&view, &spec, t0, t1, &self.kernel)?;
                let w = if self.settings.decay > 0.0 {
                    (-(t0 - from) / self.settings.decay).exp() as f32
                } else {
                    1.0
                };
                for (c, &p) in self.cells.iter_mut().zip(self.occupancy.layer(0)) {
                    *c = c.max(w * p);
                }
            }
        }
        msg.header.stamp = header.stamp;
        msg.header.frame_id.clone_from(&header.frame_id);
        msg.info.map_load_time = header.stamp;
        msg.info.resolution = spec.resolution as f32;
        msg.info.width = spec.width as u32;
        msg.info.height = spec.height as u32;
        msg.info.origin = Pose {
            position: Point {
                x: spec.origin[0],
                y: spec.origin[1],
                z: 0.0,
            },
            orientation: Quaternion::default(),
        };
        msg.data.clear();
        let peak = self.peak;
        msg.data
            .extend(self.cells.iter().map(|&p| percent(p / peak)));
        Ok(())
    }
}

/// A probability as a cell value: rounded percent, 0..100.
pub fn percent(p: f32) -> i8 {
    if p.is_finite() {
        (p * 100.0).round().clamp(0.0, 100.0) as i8
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One person walking east at 1 m/s from (0, 0): `k` identical samples, 10 steps of 0.5 s.
    fn walker(k: usize) -> Samples {
        let steps = 10;
        let mut positions = Vec::new();
        for _ in 0..k {
            positions.extend((1..=steps).map(|j| [j as f32 * 0.5, 0.0]));
        }
        Samples {
            agents: 1,
            k,
            steps,
            positions,
            lens: vec![steps as u32; k],
            scores: Vec::new(),
        }
    }

    fn grid(decay: f64, from: f64, to: f64) -> GridBuilder {
        GridBuilder::new(GridSettings {
            origin: [-2.0, -2.0],
            size: [8.0, 4.0],
            resolution: 0.2,
            from,
            to,
            decay,
        })
    }

    fn cell(g: &GridBuilder, msg: &OccupancyGrid, x: f64, y: f64) -> i8 {
        let (row, col) = g.spec().cell_of(x, y).unwrap();
        msg.data[row * msg.info.width as usize + col]
    }

    #[test]
    fn the_walkers_path_in_the_window_is_occupied_and_nothing_else() {
        let mut g = grid(0.0, 0.0, 2.0);
        let mut msg = OccupancyGrid::default();
        let header = Header {
            stamp: crate::msg::Time { sec: 5, nanosec: 0 },
            frame_id: "map".into(),
        };
        g.fill(&mut msg, &header, &walker(4), [[0.0, 0.0]].into_iter(), 0.5)
            .unwrap();
        assert_eq!((msg.info.width, msg.info.height), (40, 20));
        assert_eq!(msg.data.len(), 800);
        assert_eq!(msg.info.origin.position.x, -2.0);
        assert_eq!(
            (msg.header.frame_id.as_str(), msg.info.map_load_time.sec),
            ("map", 5)
        );
        // on the path within 0..2 s (x 0..2 m): as occupied as under a standing person
        // (the samples agree: the kernel is the person's alone); beyond it and off it: not
        for x in [0.1, 1.0, 1.9] {
            assert!(
                cell(&g, &msg, x, 0.1) >= 85,
                "x {x}: {}",
                cell(&g, &msg, x, 0.1)
            );
        }
        assert_eq!(cell(&g, &msg, 4.5, 0.1), 0);
        assert_eq!(cell(&g, &msg, 1.0, 1.9), 0);
        assert!(msg.data.iter().all(|&v| (0..=100).contains(&v)));
    }

    #[test]
    fn decay_lowers_later_passes_only() {
        let mut flat = OccupancyGrid::default();
        let mut decayed = OccupancyGrid::default();
        let header = Header::default();
        let mut a = grid(0.0, 0.0, 4.0);
        let mut b = grid(1.0, 0.0, 4.0);
        a.fill(
            &mut flat,
            &header,
            &walker(4),
            [[0.0, 0.0]].into_iter(),
            0.5,
        )
        .unwrap();
        b.fill(
            &mut decayed,
            &header,
            &walker(4),
            [[0.0, 0.0]].into_iter(),
            0.5,
        )
        .unwrap();
        // at the start: the same; 3 m on (3 s later): about exp(-3) of it
        assert_eq!(cell(&a, &flat, 0.1, 0.1), cell(&b, &decayed, 0.1, 0.1));
        let (f, d) = (
            cell(&a, &flat, 3.1, 0.1) as f64,
            cell(&b, &decayed, 3.1, 0.1) as f64,
        );
        assert!(f > 20.0 && d < f * 0.15 && d > 0.0, "{f} {d}");
    }

    #[test]
    fn no_people_is_an_empty_grid_and_bad_windows_are_refused() {
        let mut g = grid(0.0, 0.0, 2.0);
        let mut msg = OccupancyGrid::default();
        let empty = Samples::default();
        g.fill(
            &mut msg,
            &Header::default(),
            &empty,
            std::iter::empty(),
            0.4,
        )
        .unwrap();
        assert!(msg.data.iter().all(|&v| v == 0) && msg.data.len() == 800);
        let s = |from, to, decay, resolution| GridSettings {
            from,
            to,
            decay,
            resolution,
            ..GridSettings::default()
        };
        assert!(s(0.0, 4.0, 0.0, 0.1).check(12.0).is_ok());
        assert!(s(2.0, 1.0, 0.0, 0.1).check(12.0).is_err());
        assert!(s(0.0, 13.0, 0.0, 0.1).check(12.0).is_err());
        assert!(s(-1.0, 2.0, 0.0, 0.1).check(12.0).is_err());
        assert!(s(0.0, 2.0, -1.0, 0.1).check(12.0).is_err());
        assert!(s(0.0, 2.0, 0.0, 0.0).check(12.0).is_err());
        assert!(
            s(0.0, 2.0, 0.0, 1e-6).check(12.0).is_err(),
            "too many cells"
        );
        assert_eq!(
            (
                percent(0.004),
                percent(0.5),
                percent(1.2),
                percent(f32::NAN)
            ),
            (0, 50, 100, 0)
        );
        // the peak: a normal's mass over a cell, against the error function's values
        // (erf(1 / (2 sqrt 2)) = 0.382925 per axis for a 0.3 m cell under sigma 0.3)
        assert!((peak_mass(0.3, 0.3) - 0.382_925f64.powi(2)).abs() < 1e-5);
    }
}
