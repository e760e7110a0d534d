//! Daemon settings, the maps to serve, and the errors that stop a daemon from starting.

use std::path::PathBuf;
use std::time::Duration;

use cliff_client::protocol::{self, Limits};

use super::learning::LearnSettings;

/// A map to serve: a name and the file it comes from (`None`: the built-in demo scene).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MapSpec {
    /// Name clients ask for.
    pub name: String,
    /// CSV or snapshot file; `None` for the built-in scene.
    pub path: Option<PathBuf>,
}

impl std::str::FromStr for MapSpec {
    type Err = String;
    /// `NAME=PATH`.
    fn from_str(s: &str) -> Result<Self, String> {
        let (name, path) = s
            .split_once('=')
            .ok_or_else(|| format!("'{s}' is not NAME=PATH (for example hall=maps/hall.csv)"))?;
        protocol::encode_map_name(name)?;
        if name.contains('@') {
            return Err(format!(
                "map name '{name}' holds '@', which clients use to ask for a learned version (NAME@VERSION)"
            ));
        }
        if path.is_empty() {
            return Err(format!("map '{name}' has an empty path"));
        }
        Ok(MapSpec {
            name: name.to_string(),
            path: Some(PathBuf::from(path)),
        })
    }
}

/// The default radius limit, in grid steps of each map: the paper evaluates radii up to
/// 3 m on a 1 m grid.
pub const RADIUS_LIMIT_STEPS: f64 = 4.0;

/// Sampling radii whose neighbour tables are built when a map loads (those within the
/// map's radius limit): the paper's THÖR radius `sqrt(0.5)` (the clients' default) and
/// its rounding 0.7071 (the command line's), 0.5 m, and the ATC radius 1 m.
#[allow(clippy::approx_constant)]
pub const DEFAULT_TABLE_RADII: [f64; 4] = [std::f64::consts::FRAC_1_SQRT_2, 0.7071, 0.5, 1.0];

/// Memory the neighbour tables of one map may take together, unless set: 64 MiB.
pub const DEFAULT_TABLE_BUDGET: usize = 64 << 20;

/// Predicted positions in one chunk of a request, unless set: about 0.2 ms of work on
/// one core, the longest a small request waits behind a large one's chunk.
pub const DEFAULT_CHUNK_POSITIONS: usize = 8192;

/// The number of cores this process may use (1 when unknown).
pub fn available_cores() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

/// Daemon settings. The iceoryx2 service limits are derived from them.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// iceoryx2 service name.
    pub service: String,
    /// iceoryx2 prefix (namespace); `None`: iceoryx2's default.
    pub prefix: Option<String>,
    /// Maps; empty: the built-in demo scene under the name `demo`.
    pub maps: Vec<MapSpec>,
    /// Per-request limits.
    pub limits: Limits,
    /// Largest sampling radius (m) a request may ask for, for every map; `None`:
    /// [`RADIUS_LIMIT_STEPS`] grid steps of each map.
    pub max_radius: Option<f64>,
    /// Radii whose neighbour tables are built (and kept) when a map loads or reloads;
    /// other radii within the limit are served by the grid scan until a background
    /// thread has built their table.
    pub table_radii: Vec<f64>,
    /// Memory (bytes) the neighbour tables of one map may take together; the least
    /// recently used tables of other radii are evicted to stay within it.
    pub table_budget: usize,
    /// Predicted positions per chunk: large requests are cut into chunks of whole
    /// agents that take turns with other requests.
    pub chunk_positions: usize,
    /// Client processes served at once.
    pub max_clients: usize,
    /// Requests one client may have in flight (a local client, and each remote session
    /// over zenoh).
    pub max_active_requests: usize,
    /// Remote (zenoh) sessions with requests in flight at once; the scheduler keeps room
    /// for their requests beside the local clients'. Used with the feature `zenoh`.
    pub max_remote_sessions: usize,
    /// How long the loop busy-polls after the last request before it sleeps.
    pub idle_spin: Duration,
    /// Threads predicting chunks at once, of several requests or one (the serving thread is
    /// one of them); the number of cores by default.
    pub workers: usize,
    /// How often resources of dead processes (clients killed with SIGKILL) are removed.
    pub cleanup_interval: Duration,
    /// Maps that learn from observations, and how (none by default).
    pub learn: LearnSettings,
    /// The motion model file (`.motion`, `cliff motion fit`) that the methods `motion`
    /// and `improved` start from (`None`: the built-in model).
    pub motion_model: Option<PathBuf>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            service: cliff_client::DEFAULT_SERVICE.to_string(),
            prefix: None,
            maps: Vec::new(),
            limits: Limits::default(),
            max_radius: None,
            table_radii: DEFAULT_TABLE_RADII.to_vec(),
            table_budget: DEFAULT_TABLE_BUDGET,
            chunk_positions: DEFAULT_CHUNK_POSITIONS,
            max_clients: 16,
            max_active_requests: 2,
            max_remote_sessions: 8,
            idle_spin: Duration::from_millis(1),
            cleanup_interval: Duration::from_secs(1),
            workers: available_cores(),
            motion_model: None,
            learn: LearnSettings::default(),
        }
    }
}

impl Settings {
    /// Check the settings that do not need the maps or iceoryx2.
    pub fn check(&self) -> Result<(), StartError> {
        let bad = |m: String| Err(StartError::Settings(m));
        let l = self.limits;
        if l.max_agents == 0 || l.max_k == 0 || l.max_steps == 0 || l.max_history == 0 {
            return bad("limits on agents, k, steps and history must be at least 1".into());
        }
        if l.max_history > protocol::MAX_HISTORY {
            return bad(format!(
                "max history {} is above the protocol's {}",
                l.max_history,
                protocol::MAX_HISTORY
            ));
        }
        if self.workers == 0 || self.workers > 256 {
            return bad("workers must be between 1 and 256".into());
        }
        if self.max_clients == 0 || self.max_active_requests == 0 || self.max_remote_sessions == 0 {
            return bad(
                "max clients, max active requests and max remote sessions must be at least 1"
                    .into(),
            );
        }
        let words = l.max_payload_words();
        if words > (1 << 28) {
            return bad(format!(
                "agents x k x steps = {} x {} x {} makes responses of {} MB; lower a limit",
                l.max_agents,
                l.max_k,
                l.max_steps,
                (words * 4) >> 20
            ));
        }
        if let Some(r) = self.max_radius
            && !(r.is_finite() && r > 0.0 && r <= 1000.0)
        {
            return bad(format!(
                "max radius {r} m is not a positive number of at most 1000 m"
            ));
        }
        if let Some(r) = self
            .table_radii
            .iter()
            .find(|r| !(r.is_finite() && **r > 0.0))
        {
            return bad(format!("table radius {r} is not a positive number"));
        }
        if self.chunk_positions == 0 {
            return bad("chunk positions must be at least 1".into());
        }
        Ok(())
    }
}

/// Errors that stop the daemon from starting.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// A map file could not be loaded.
    #[error("map '{name}': {source}")]
    Map {
        /// Map name.
        name: String,
        /// Why.
        source: cliff::map::MapError,
    },
    /// Settings are unusable.
    #[error("{0}")]
    Settings(String),
    /// The motion model file could not be loaded.
    #[error("motion model: {0}")]
    MotionModel(cliff::motion::MotionError),
    /// iceoryx2 refused (permissions, a service of another version, ...).
    #[error("iceoryx2: {0}")]
    Ipc(String),
    /// Another daemon already serves the service.
    #[error(
        "another cliffd already serves '{0}' (stop it, or use another --service or --prefix; see docs/troubleshooting.md)"
    )]
    AlreadyServed(String),
    /// zenoh refused (endpoint in use, bad configuration).
    #[error("zenoh: {0}")]
    Zenoh(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_specs_parse_and_refuse_bad_ones() {
        let m: MapSpec = "hall=maps/hall.csv".parse().unwrap();
        assert_eq!(m.name, "hall");
        assert_eq!(m.path, Some(PathBuf::from("maps/hall.csv")));
        assert!("hall".parse::<MapSpec>().unwrap_err().contains("NAME=PATH"));
        assert!("=x.csv".parse::<MapSpec>().unwrap_err().contains("empty"));
        assert!(
            "hall="
                .parse::<MapSpec>()
                .unwrap_err()
                .contains("empty path")
        );
        let long = format!("{}=x.csv", "n".repeat(64));
        assert!(long.parse::<MapSpec>().is_err());
        assert!(
            "hall@2=x.csv"
                .parse::<MapSpec>()
                .unwrap_err()
                .contains("NAME@VERSION")
        );
    }

    #[test]
    fn bad_settings_are_refused() {
        let bad = |f: &dyn Fn(&mut Settings)| {
            let mut s = Settings::default();
            f(&mut s);
            s.check().expect_err("refused").to_string()
        };
        assert!(bad(&|s| s.limits.max_k = 0).contains("at least 1"));
        assert!(bad(&|s| s.limits.max_history = 65).contains("max history"));
        assert!(bad(&|s| s.workers = 0).contains("workers"));
        assert!(bad(&|s| s.max_clients = 0).contains("at least 1"));
        assert!(bad(&|s| s.max_radius = Some(f64::NAN)).contains("max radius"));
        assert!(bad(&|s| s.max_radius = Some(1e9)).contains("max radius"));
        assert!(bad(&|s| s.table_radii = vec![0.5, -1.0]).contains("table radius -1"));
        assert!(bad(&|s| s.chunk_positions = 0).contains("chunk"));
        assert!(Settings::default().check().is_ok());
        assert_eq!(Settings::default().workers, available_cores());
    }
}
