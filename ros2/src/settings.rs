//! The node's settings: ROS-style parameters (a YAML parameters file, `-p name:=value`
//! overrides), the node name and namespace, and topic remappings.
//!
//! Parameters file shape (as `ros2 run --ros-args --params-file` takes it):
//!
//! ```yaml
//! /**:                 # every node; a node's own entry (cliff_ros2 or /ns/cliff_ros2) wins
//!   ros__parameters:
//!     k: 20
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context as _, Result, bail};
use cliff::predict::{Method, Params};
use serde::{Deserialize, Serialize};
use serde_yaml_ng::{Mapping, Value};

use crate::grid::GridSettings;
use crate::predictor::{Link, PredictSettings, Source, TimeOfDay, ZENOH_MISSING};
use crate::tracks::{KeeperSettings, StaticTransform};

/// Every parameter, with its default (the names are the YAML keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Parameters {
    /// Map file to predict from in-process (`.csv`, `.cliff` or a time-of-day set);
    /// empty: ask the cliffd daemon.
    pub map_file: String,
    /// The map's name at the daemon.
    pub daemon_map: String,
    /// The daemon's service (its iceoryx2 service; its zenoh key expression over zenoh).
    pub daemon_service: String,
    /// Reach a cliffd on another host over zenoh at this endpoint (`tcp/HOST:7447`,
    /// `quic/HOST:7447`); empty: the cliffd of this host over shared memory, unless
    /// `daemon_zenoh_config` is set. Needs the cargo feature `zenoh`.
    pub daemon_zenoh: String,
    /// A zenoh configuration file for reaching cliffd (TLS certificates, endpoints); set
    /// alone, it names the endpoints itself. Needs the cargo feature `zenoh`.
    pub daemon_zenoh_config: String,
    /// Deadline of one daemon call (s).
    pub daemon_deadline: f64,
    /// Send every track's rows to the daemon as observations of `daemon_map`, for a
    /// daemon that learns it (`cliffd --learn NAME`).
    pub observe: bool,
    /// Map file drawn as arrows on the map topic when predicting through the daemon
    /// (in-process, the map predicted from is drawn).
    pub map_markers_file: String,
    /// The map's frame id.
    pub map_frame: String,
    /// Static transforms into the map frame, each "frame x y yaw" (m, m, rad).
    pub static_transforms: Vec<String>,
    /// Predictions per second (0: after every input message).
    pub rate: f64,
    /// Method: cliff, cvm, improved, motion (the learned motion model) or cvm-last.
    pub method: String,
    /// Samples per person.
    pub k: usize,
    /// Horizon (s).
    pub horizon: f64,
    /// Step (s).
    pub dt: f64,
    /// Kernel beta.
    pub beta: f64,
    /// Sampling radius (m).
    pub radius: f64,
    /// Seed of every cycle.
    pub seed: u64,
    /// Score each sample (its log-likelihood).
    pub scores: bool,
    /// Which map of a time-of-day set: stamp, all-day or now.
    pub time_of_day: String,
    /// Seconds added to the stamps to get the map's clock.
    pub clock_offset: f64,
    /// Observations kept per track (at most 64, the daemon's limit).
    pub history: usize,
    /// Seconds of a track's newest observations predicted from (0: all kept).
    pub history_seconds: f64,
    /// Forget a track after this many seconds without an observation.
    pub track_timeout: f64,
    /// At most this many tracks.
    pub max_tracks: usize,
    /// Input QoS reliability: best_effort (receives from reliable and best-effort
    /// publishers) or reliable.
    pub input_reliability: String,
    /// Line width of the sample markers (m).
    pub marker_width: f64,
    /// Seconds a sample marker stays without refresh.
    pub marker_lifetime: f64,
    /// Map arrows are as long as this many seconds of their mean speed.
    pub map_arrow_seconds: f64,
    /// Publish the occupancy grid (`cliff/occupancy`).
    pub grid: bool,
    /// The grid's corner of cell (0, 0) in the map frame, [x, y] (m).
    pub grid_origin: Vec<f64>,
    /// The grid's width and height (m).
    pub grid_size: Vec<f64>,
    /// The side of a grid cell (m).
    pub grid_resolution: f64,
    /// The grid's time window: from this many seconds after the prediction's start ...
    pub grid_from: f64,
    /// ... to this many (at most the horizon).
    pub grid_to: f64,
    /// Seconds over which later passes count less in the grid (0: no decay).
    pub grid_decay: f64,
    /// Paths per person on the objects topic (`PredictedObjects`): the best by score,
    /// at most `k`.
    pub object_paths: usize,
    /// Seconds between two warnings of one kind.
    pub warn_period: f64,
    /// Accepted for launch files; stamps are used whatever it says.
    pub use_sim_time: bool,
}

impl Default for Parameters {
    fn default() -> Self {
        let p = Params::default();
        Parameters {
            map_file: String::new(),
            daemon_map: "demo".into(),
            daemon_service: cliff_client::DEFAULT_SERVICE.into(),
            daemon_zenoh: String::new(),
            daemon_zenoh_config: String::new(),
            daemon_deadline: 0.2,
            observe: false,
            map_markers_file: String::new(),
            map_frame: "map".into(),
            static_transforms: Vec::new(),
            rate: 10.0,
            method: "cliff".into(),
            k: p.k,
            horizon: p.horizon,
            dt: p.dt,
            beta: p.beta,
            radius: p.radius,
            seed: 0,
            scores: false,
            time_of_day: "stamp".into(),
            clock_offset: 0.0,
            history: cliff_client::protocol::MAX_HISTORY as usize,
            history_seconds: 3.2,
            track_timeout: 2.0,
            max_tracks: 64,
            input_reliability: "best_effort".into(),
            marker_width: 0.03,
            marker_lifetime: 1.0,
            map_arrow_seconds: 1.0,
            object_paths: crate::engine::DEFAULT_OBJECT_PATHS,
            grid: true,
            grid_origin: GridSettings::default().origin.to_vec(),
            grid_size: GridSettings::default().size.to_vec(),
            grid_resolution: GridSettings::default().resolution,
            grid_from: GridSettings::default().from,
            grid_to: GridSettings::default().to,
            grid_decay: GridSettings::default().decay,
            warn_period: 5.0,
            use_sim_time: false,
        }
    }
}

/// Default topic names (relative: resolved in the node's namespace), by key.
pub const TOPICS: [(&str, &str); 7] = [
    ("people", "people"),
    ("tracked_objects", "tracked_objects"),
    ("predictions", "cliff/predictions"),
    ("markers", "cliff/markers"),
    ("map_markers", "cliff/map_markers"),
    ("objects", "cliff/objects"),
    ("occupancy", "cliff/occupancy"),
];

/// Everything the node runs with.
#[derive(Debug, Clone)]
pub struct Settings {
    /// Node name.
    pub name: String,
    /// Node namespace ("/" or "/a/b").
    pub namespace: String,
    /// The parameters.
    pub params: Parameters,
    /// Topic names after remapping, by key of [`TOPICS`].
    pub topics: BTreeMap<&'static str, String>,
}

/// Read a parameter value as ROS 2 does: a YAML scalar or list (`-p k:=20`,
/// `-p map_frame:=odom`, `-p static_transforms:="['odom 0 0 0']"`).
fn yaml_value(s: &str) -> Value {
    serde_yaml_ng::from_str(s).unwrap_or_else(|_| Value::String(s.to_string()))
}

/// The `ros__parameters` of every entry of a parameters file that names this node
/// (`/**`, `name`, `/name`, `/ns/name`), merged in that order.
pub fn file_parameters(path: &Path, name: &str, namespace: &str) -> Result<Mapping> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading parameters file {}", path.display()))?;
    let doc: Value = serde_yaml_ng::from_str(&text)
        .with_context(|| format!("parameters file {}", path.display()))?;
    let Value::Mapping(top) = doc else {
        bail!(
            "parameters file {}: expected a mapping of node names to ros__parameters",
            path.display()
        );
    };
    let full = if namespace == "/" {
        format!("/{name}")
    } else {
        format!("{namespace}/{name}")
    };
    let mut out = Mapping::new();
    for key in [
        "/**".to_string(),
        name.to_string(),
        format!("/{name}"),
        full,
    ] {
        if let Some(entry) = top.get(key.as_str()) {
            let params = entry.get("ros__parameters").with_context(|| {
                format!(
                    "parameters file {}: entry '{key}' has no ros__parameters",
                    path.display()
                )
            })?;
            let Value::Mapping(m) = params else {
                bail!(
                    "parameters file {}: {key}.ros__parameters is not a mapping",
                    path.display()
                );
            };
            for (k, v) in m {
                out.insert(k.clone(), v.clone());
            }
        }
    }
    Ok(out)
}

/// Build [`Parameters`] from file parameters and `name:=value` overrides (later wins).
pub fn parameters(file: Mapping, overrides: &[String]) -> Result<Parameters> {
    let mut m = file;
    for o in overrides {
        let (k, v) = o
            .split_once(":=")
            .with_context(|| format!("parameter override '{o}' is not name:=value"))?;
        m.insert(Value::String(k.to_string()), yaml_value(v));
    }
    // one key at a time first, so an error names its parameter
    for (k, v) in &m {
        let mut one = Mapping::new();
        one.insert(k.clone(), v.clone());
        if let Err(e) = serde_yaml_ng::from_value::<Parameters>(Value::Mapping(one)) {
            let name = k.as_str().map_or_else(|| format!("{k:?}"), str::to_string);
            let value = serde_yaml_ng::to_string(v).unwrap_or_default();
            bail!("parameter {name} = {}: {e}", value.trim());
        }
    }
    let p: Parameters = serde_yaml_ng::from_value(Value::Mapping(m)).context("parameters")?;
    p.check()?;
    Ok(p)
}

impl Parameters {
    /// Reject values no cycle could use.
    pub fn check(&self) -> Result<()> {
        let pos = |v: f64, n: &str| -> Result<()> {
            if !(v.is_finite() && v > 0.0) {
                bail!("parameter {n} must be a positive number, not {v}");
            }
            Ok(())
        };
        pos(self.horizon, "horizon")?;
        pos(self.dt, "dt")?;
        pos(self.radius, "radius")?;
        pos(self.track_timeout, "track_timeout")?;
        pos(self.daemon_deadline, "daemon_deadline")?;
        pos(self.warn_period, "warn_period")?;
        if !(self.rate.is_finite() && self.rate >= 0.0) {
            bail!(
                "parameter rate must be 0 (on each input) or positive, not {}",
                self.rate
            );
        }
        if !(self.clock_offset.is_finite()
            && self.history_seconds.is_finite()
            && self.history_seconds >= 0.0)
        {
            bail!(
                "parameters clock_offset and history_seconds must be finite (history_seconds >= 0)"
            );
        }
        if self.k == 0 || self.max_tracks == 0 || self.history < 2 {
            bail!("parameters k and max_tracks must be at least 1, history at least 2");
        }
        if self.observe && !self.map_file.is_empty() {
            bail!(
                "parameter observe: observations go to cliffd, but map_file '{}' predicts in-process (set map_file to \"\" and daemon_map to the map cliffd learns)",
                self.map_file
            );
        }
        self.link()?;
        self.method()?;
        self.time_of_day()?;
        self.grid_settings()?;
        self.transforms()?;
        self.best_effort()?;
        let steps = self.predict().params.steps();
        if steps == 0 {
            bail!(
                "horizon {} is shorter than one step of dt {}",
                self.horizon,
                self.dt
            );
        }
        Ok(())
    }

    /// The occupancy grid's settings, checked (also when `grid` is off).
    pub fn grid_settings(&self) -> Result<GridSettings> {
        let pair = |v: &[f64], name: &str| -> Result<[f64; 2]> {
            match v {
                [a, b] => Ok([*a, *b]),
                _ => bail!("parameter {name} must be two numbers [x, y], not {v:?}"),
            }
        };
        let s = GridSettings {
            origin: pair(&self.grid_origin, "grid_origin")?,
            size: pair(&self.grid_size, "grid_size")?,
            resolution: self.grid_resolution,
            from: self.grid_from,
            to: self.grid_to,
            decay: self.grid_decay,
        };
        s.check(self.horizon)
            .map_err(|e| anyhow::anyhow!("parameter {e}"))?;
        Ok(s)
    }

    /// How the daemon is reached: zenoh when `daemon_zenoh` or `daemon_zenoh_config` is
    /// set (an error in a build without the cargo feature `zenoh`, with the build line;
    /// and when `map_file` predicts in-process, which needs no daemon), else shared
    /// memory.
    pub fn link(&self) -> Result<Link> {
        if self.daemon_zenoh.is_empty() && self.daemon_zenoh_config.is_empty() {
            return Ok(Link::SharedMemory);
        }
        let which = if self.daemon_zenoh.is_empty() {
            "daemon_zenoh_config"
        } else {
            "daemon_zenoh"
        };
        if !self.map_file.is_empty() {
            bail!(
                "parameter {which}: cliffd is reached over zenoh, but map_file '{}' predicts in-process (set map_file to \"\" to predict through the remote cliffd)",
                self.map_file
            );
        }
        if !cfg!(feature = "zenoh") {
            bail!("parameter {which}: {ZENOH_MISSING}");
        }
        Ok(Link::Zenoh {
            endpoints: if self.daemon_zenoh.is_empty() {
                Vec::new()
            } else {
                vec![self.daemon_zenoh.clone()]
            },
            config: (!self.daemon_zenoh_config.is_empty())
                .then(|| PathBuf::from(&self.daemon_zenoh_config)),
        })
    }

    /// The method.
    pub fn method(&self) -> Result<Method> {
        self.method
            .parse::<Method>()
            .map_err(|e| anyhow::anyhow!("parameter method: {e}"))
    }

    /// The time-of-day rule.
    pub fn time_of_day(&self) -> Result<TimeOfDay> {
        self.time_of_day
            .parse::<TimeOfDay>()
            .map_err(|e| anyhow::anyhow!("parameter time_of_day: {e}"))
    }

    /// Whether the input subscription is best-effort.
    pub fn best_effort(&self) -> Result<bool> {
        match self.input_reliability.as_str() {
            "best_effort" => Ok(true),
            "reliable" => Ok(false),
            o => bail!("parameter input_reliability: '{o}' (expected best_effort or reliable)"),
        }
    }

    /// The static transforms.
    pub fn transforms(&self) -> Result<Vec<StaticTransform>> {
        self.static_transforms
            .iter()
            .map(|s| {
                let f: Vec<&str> = s.split_whitespace().collect();
                let num = |i: usize| -> Result<f64> {
                    let v: f64 = f[i].parse().with_context(|| {
                        format!("static transform '{s}': '{}' is not a number", f[i])
                    })?;
                    if !v.is_finite() {
                        bail!("static transform '{s}': {v} is not finite");
                    }
                    Ok(v)
                };
                if f.len() != 4 {
                    bail!("static transform '{s}': expected \"frame x y yaw\"");
                }
                Ok(StaticTransform {
                    frame: f[0].to_string(),
                    x: num(1)?,
                    y: num(2)?,
                    yaw: num(3)?,
                })
            })
            .collect()
    }

    /// What the predictor asks for.
    pub fn predict(&self) -> PredictSettings {
        PredictSettings {
            params: Params {
                method: self.method().unwrap_or(Method::Cliff),
                k: self.k,
                dt: self.dt,
                horizon: self.horizon,
                beta: self.beta,
                radius: self.radius,
                seed: self.seed,
                ..Params::default()
            },
            scores: self.scores,
            time_of_day: self.time_of_day().unwrap_or_default(),
            clock_offset: self.clock_offset,
        }
    }

    /// Where predictions come from.
    pub fn source(&self) -> Source {
        if self.map_file.is_empty() {
            Source::Daemon {
                service: self.daemon_service.clone(),
                link: self.link().unwrap_or_default(),
                map: self.daemon_map.clone(),
                deadline: Duration::from_secs_f64(self.daemon_deadline),
            }
        } else if self.map_file == "demo" {
            Source::Demo
        } else {
            Source::Local(PathBuf::from(&self.map_file))
        }
    }

    /// What the track keeper keeps.
    pub fn keeper(&self) -> KeeperSettings {
        KeeperSettings {
            frame_id: self.map_frame.clone(),
            transforms: self.transforms().unwrap_or_default(),
            history: self.history,
            history_seconds: self.history_seconds,
            timeout: self.track_timeout,
            max_tracks: self.max_tracks,
        }
    }
}

/// Apply `from:=to` remappings to the default topic names; `from` is a key of
/// [`TOPICS`] or a default name (`people`, `/people`).
pub fn topics(remaps: &[String]) -> Result<BTreeMap<&'static str, String>> {
    let mut out: BTreeMap<&'static str, String> =
        TOPICS.iter().map(|&(k, v)| (k, v.to_string())).collect();
    for r in remaps {
        let (from, to) = r
            .split_once(":=")
            .with_context(|| format!("remapping '{r}' is not from:=to"))?;
        let from_rel = from.trim_start_matches('/');
        let key = TOPICS
            .iter()
            .find(|(k, v)| *k == from || *v == from_rel)
            .map(|(k, _)| *k)
            .with_context(|| {
                format!(
                    "remapping '{r}': no topic '{from}' (the topics: {})",
                    TOPICS
                        .iter()
                        .map(|(_, v)| *v)
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })?;
        if to.is_empty() {
            bail!("remapping '{r}': empty target");
        }
        out.insert(key, to.to_string());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(text: &str) -> tempfile::NamedTempFile {
        let f = tempfile::NamedTempFile::new().unwrap();
        std::fs::write(f.path(), text).unwrap();
        f
    }

    #[test]
    fn defaults_check_and_match_the_paper() {
        let p = Parameters::default();
        p.check().unwrap();
        let s = p.predict();
        assert_eq!((s.params.k, s.params.steps()), (20, 30));
        assert!(matches!(p.source(), Source::Daemon { .. }));
    }

    #[test]
    fn file_entries_merge_and_overrides_win() {
        let f = file(
            "/**:\n  ros__parameters:\n    k: 5\n    map_frame: world\n\
             cliff_ros2:\n  ros__parameters:\n    k: 7\n    scores: true\n\
             other:\n  ros__parameters:\n    k: 99\n\
             /robot/cliff_ros2:\n  ros__parameters:\n    static_transforms: ['odom 1 2 0.5']\n",
        );
        let m = file_parameters(f.path(), "cliff_ros2", "/robot").unwrap();
        let p = parameters(m.clone(), &[]).unwrap();
        assert_eq!((p.k, p.scores, p.map_frame.as_str()), (7, true, "world"));
        assert_eq!(p.transforms().unwrap()[0].yaw, 0.5);
        let p = parameters(
            m,
            &[
                "k:=3".into(),
                "method:=improved".into(),
                "map_file:=demo".into(),
            ],
        )
        .unwrap();
        assert_eq!((p.k, p.method().unwrap()), (3, Method::Improved));
        assert_eq!(p.source(), Source::Demo);
    }

    #[test]
    fn bad_parameters_are_named() {
        let e = |o: &str| {
            format!(
                "{:#}",
                parameters(Mapping::new(), &[o.to_string()]).unwrap_err()
            )
        };
        assert!(e("kk:=3").contains("unknown field `kk`"), "{}", e("kk:=3"));
        assert_eq!(
            e("k:=many"),
            "parameter k = many: invalid type: string \"many\", expected usize"
        );
        assert!(e("dt:=0").contains("dt"));
        assert!(e("method:=fast").contains("method"));
        assert!(e("static_transforms:=['odom 1 2']").contains("frame x y yaw"));
        assert!(e("input_reliability:=sometimes").contains("input_reliability"));
        assert!(e("no-equals").contains("name:=value"));
        let f = file("cliff_ros2:\n  k: 3\n");
        assert!(
            format!(
                "{:#}",
                file_parameters(f.path(), "cliff_ros2", "/").unwrap_err()
            )
            .contains("ros__parameters")
        );
    }

    #[test]
    fn the_shipped_parameters_file_holds_every_parameter_at_its_default() {
        // ros2/config/cliff.yaml, the file the front page's command passes
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/cliff.yaml");
        let m = file_parameters(&path, "cliff_ros2", "/").unwrap();
        let Value::Mapping(all) = serde_yaml_ng::to_value(Parameters::default()).unwrap() else {
            panic!("the parameters serialize as a mapping");
        };
        let names = |m: &Mapping| {
            m.keys()
                .map(|k| k.as_str().unwrap_or_default().to_string())
                .collect::<std::collections::BTreeSet<_>>()
        };
        assert_eq!(
            names(&m),
            names(&all),
            "the file names every parameter once"
        );
        assert_eq!(parameters(m, &[]).unwrap(), Parameters::default());
        // a renamed node in a namespace reads it as well
        let m = file_parameters(&path, "people_predictor", "/robot").unwrap();
        assert_eq!(parameters(m, &[]).unwrap(), Parameters::default());
    }

    #[test]
    fn daemon_zenoh_reaches_cliffd_over_zenoh_or_names_the_build_line() {
        let p = parameters(Mapping::new(), &["daemon_zenoh:=tcp/192.0.2.7:7447".into()]);
        if cfg!(feature = "zenoh") {
            let p = p.unwrap();
            assert_eq!(
                p.link().unwrap(),
                Link::Zenoh {
                    endpoints: vec!["tcp/192.0.2.7:7447".into()],
                    config: None
                }
            );
            assert!(matches!(
                p.source(),
                Source::Daemon {
                    link: Link::Zenoh { .. },
                    ..
                }
            ));
        } else {
            let e = format!("{:#}", p.unwrap_err());
            assert!(
                e.contains("parameter daemon_zenoh")
                    && e.contains("cargo build --release -p cliff-ros2 --features zenoh"),
                "{e}"
            );
        }
        // a configuration file alone is zenoh too; with an in-process map it is refused
        let e = parameters(
            Mapping::new(),
            &[
                "daemon_zenoh_config:=/etc/cliff/robot.json5".into(),
                "map_file:=demo".into(),
            ],
        )
        .unwrap_err();
        let e = format!("{e:#}");
        assert!(
            e.contains("parameter daemon_zenoh_config") && e.contains("map_file"),
            "{e}"
        );
        assert_eq!(Parameters::default().link().unwrap(), Link::SharedMemory);
    }

    #[test]
    fn remapping_by_key_or_name() {
        let t = topics(&[
            "people:=/tracker/people".into(),
            "cliff/markers:=viz".into(),
        ])
        .unwrap();
        assert_eq!(t["people"], "/tracker/people");
        assert_eq!(t["markers"], "viz");
        assert_eq!(t["predictions"], "cliff/predictions");
        assert_eq!(t["tracked_objects"], "tracked_objects");
        let t =
            topics(&["tracked_objects:=/perception/object_recognition/tracking/objects".into()])
                .unwrap();
        assert_eq!(
            t["tracked_objects"],
            "/perception/object_recognition/tracking/objects"
        );
        assert!(topics(&["/nope:=x".into()]).is_err());
    }
}
