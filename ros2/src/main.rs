//! `cliff-ros2`: the node. `cliff-ros2 --help` lists the parameters.

use std::path::PathBuf;

use anyhow::{Context as _, Result};
use clap::Parser;
use cliff_ros2::settings::{self, Parameters, Settings, TOPICS};
use serde_yaml_ng::Mapping;

/// One line per parameter, for --help (the defaults are printed beside them).
const PARAM_HELP: &[(&str, &str)] = &[
    (
        "map_file",
        "map to predict from in-process (.csv, .cliff, a time-of-day set, or 'demo'); empty: ask cliffd",
    ),
    ("daemon_map", "the map's name at cliffd"),
    (
        "daemon_service",
        "cliffd's service (iceoryx2 service; zenoh key expression over zenoh)",
    ),
    (
        "daemon_zenoh",
        "reach cliffd on another host over zenoh at this endpoint (tcp/HOST:7447); needs the build feature zenoh",
    ),
    (
        "daemon_zenoh_config",
        "zenoh configuration file for reaching cliffd (TLS certificates, endpoints); needs the build feature zenoh",
    ),
    ("daemon_deadline", "seconds one cliffd call may take"),
    (
        "observe",
        "send every track's rows to cliffd as observations of daemon_map (cliffd --learn NAME learns from them)",
    ),
    (
        "map_markers_file",
        "map file drawn as arrows when predicting through cliffd",
    ),
    (
        "map_frame",
        "the map's frame id; input in another frame is skipped unless transformed",
    ),
    (
        "static_transforms",
        "list of \"frame x y yaw\": frame -> map_frame (m, m, rad)",
    ),
    (
        "rate",
        "predictions per second; 0: after every input message",
    ),
    ("method", "cliff, cvm, improved, motion or cvm-last"),
    ("k", "samples per person"),
    ("horizon", "prediction horizon (s)"),
    ("dt", "time step of the samples (s)"),
    (
        "beta",
        "kernel beta (how strongly the heading turns to the map)",
    ),
    ("radius", "sampling radius (m)"),
    (
        "seed",
        "seed of every cycle's random generator (request c of 32 people: seed + c)",
    ),
    (
        "scores",
        "score each sample (log-likelihood; markers shaded by it)",
    ),
    (
        "time_of_day",
        "map of a time-of-day set: stamp (stamp + clock_offset), all-day, now",
    ),
    (
        "clock_offset",
        "seconds added to stamps to get the map's clock",
    ),
    (
        "history",
        "observations kept per track (at most 64, cliffd's limit)",
    ),
    (
        "history_seconds",
        "seconds of a track's newest observations predicted from (0: all kept)",
    ),
    (
        "track_timeout",
        "forget a track after this many seconds without an observation",
    ),
    (
        "max_tracks",
        "at most this many tracks (new ids beyond are skipped and counted)",
    ),
    (
        "input_reliability",
        "best_effort (matches reliable and best-effort publishers) or reliable",
    ),
    ("marker_width", "line width of the sample markers (m)"),
    (
        "marker_lifetime",
        "seconds a sample marker stays without refresh",
    ),
    (
        "map_arrow_seconds",
        "map arrows are this many seconds of their mean speed long",
    ),
    ("grid", "publish the occupancy grid (cliff/occupancy)"),
    (
        "grid_origin",
        "[x, y] of the grid's corner (cell 0, 0) in the map frame (m)",
    ),
    ("grid_size", "[width, height] of the grid (m)"),
    ("grid_resolution", "side of a grid cell (m)"),
    (
        "grid_from",
        "the grid's window starts this many seconds after the last observation",
    ),
    ("grid_to", "... and ends this many (at most the horizon)"),
    (
        "grid_decay",
        "seconds over which later passes count less in the grid (0: no decay)",
    ),
    (
        "object_paths",
        "paths per person on the objects topic, the best by score (at most k)",
    ),
    ("warn_period", "seconds between two warnings of one kind"),
    (
        "use_sim_time",
        "accepted for launch files; the header stamps are always used",
    ),
];

fn after_help() -> String {
    let defaults = serde_yaml_ng::to_value(Parameters::default()).expect("parameters serialize");
    let mut s = String::from(
        "Parameters (-p NAME:=VALUE, or a --params-file of ROS 2's shape: `/**: {ros__parameters: {k: 20}}`):\n",
    );
    for (name, help) in PARAM_HELP {
        let d = defaults
            .get(*name)
            .map(|v| serde_yaml_ng::to_string(v).unwrap_or_default())
            .unwrap_or_default();
        s.push_str(&format!("  {name:<18} {help} [default: {}]\n", d.trim()));
    }
    s.push_str("\nTopics (relative names resolve in the namespace; -r FROM:=TO remaps):\n");
    let types = [
        (
            "people",
            "people_msgs/msg/People",
            "input: name = track id, header stamp and frame",
        ),
        (
            "tracked_objects",
            "autoware_perception_msgs/msg/TrackedObjects",
            "input: pedestrians (most probable label 7), uuid = track id",
        ),
        (
            "predictions",
            "cliff_msgs/msg/Predictions",
            "output: k samples per person",
        ),
        (
            "markers",
            "visualization_msgs/msg/MarkerArray",
            "output: a line strip per sample",
        ),
        (
            "map_markers",
            "visualization_msgs/msg/MarkerArray",
            "output, latched: the map as arrows",
        ),
        (
            "objects",
            "autoware_perception_msgs/msg/PredictedObjects",
            "output: the people as Autoware's predicted pedestrians",
        ),
        (
            "occupancy",
            "nav_msgs/msg/OccupancyGrid",
            "output, latched: chance (%) of someone in each cell in the window",
        ),
    ];
    for ((_, topic), (_, ty, use_)) in TOPICS.iter().zip(types) {
        s.push_str(&format!("  {topic:<18} {ty:<44} {use_}\n"));
    }
    s.push_str(
        "\nROS 2 launch arguments work too: --ros-args -r __node:=NAME -r __ns:=/NS --params-file FILE -p k:=10.\n\
         The DDS domain is ROS_DOMAIN_ID (default 0). Logs: RUST_LOG (default info).\n\
         Examples:\n  cliff-ros2 --map cliffmap.csv -p rate:=5.0 -r people:=/tracker/people\n  \
         cliffd --map hall=cliffmap.csv & cliff-ros2 -p daemon_map:=hall --params-file ros2/config/cliff.yaml\n",
    );
    s
}

/// ROS 2 node: people in, CLiFF-LHMP predictions and RViz2 markers out (DDS).
#[derive(Parser, Debug)]
#[command(version, about, long_about = None)]
struct Args {
    /// Predict in-process from this map file (the same numbers as cliffd); without it,
    /// predictions come from a running cliffd. Same as -p map_file:=FILE.
    #[arg(long, value_name = "FILE")]
    map: Option<PathBuf>,
    /// A ROS 2 parameters file (YAML).
    #[arg(long, value_name = "FILE")]
    params_file: Vec<PathBuf>,
    /// Set a parameter: NAME:=VALUE (a YAML value), repeatable; wins over files.
    #[arg(short = 'p', long = "param", value_name = "NAME:=VALUE")]
    param: Vec<String>,
    /// Remap a topic: FROM:=TO (FROM a default name such as `people`), repeatable;
    /// `__node:=NAME` and `__ns:=/NS` set the node's name and namespace.
    #[arg(short = 'r', long = "remap", value_name = "FROM:=TO")]
    remap: Vec<String>,
    /// Node name.
    #[arg(long, default_value = "cliff_ros2")]
    name: String,
    /// Node namespace.
    #[arg(long, default_value = "/")]
    namespace: String,
    /// DDS domain id; default: ROS_DOMAIN_ID, else 0.
    #[arg(long)]
    domain_id: Option<u16>,
    /// Print the effective parameters as a parameters file and exit.
    #[arg(long)]
    print_params: bool,
}

fn main() -> Result<()> {
    // `ros2 launch` style: drop --ros-args and the closing --
    let argv: Vec<String> = std::env::args()
        .filter(|a| a != "--ros-args" && a != "--")
        .collect();
    let args = Args::command_with_help().get_matches_from(argv);
    let args = <Args as clap::FromArgMatches>::from_arg_matches(&args)?;
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "info,rustdds=error,ros2_client=warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();

    let mut name = args.name.clone();
    let mut namespace = args.namespace.clone();
    let mut remaps = Vec::new();
    for r in &args.remap {
        if let Some(n) = r.strip_prefix("__node:=") {
            name = n.to_string();
        } else if let Some(n) = r.strip_prefix("__ns:=") {
            namespace = n.to_string();
        } else {
            remaps.push(r.clone());
        }
    }
    let mut file = Mapping::new();
    for f in &args.params_file {
        for (k, v) in settings::file_parameters(f, &name, &namespace)? {
            file.insert(k, v);
        }
    }
    let mut overrides = args.param.clone();
    if let Some(m) = &args.map {
        overrides.push(format!("map_file:={}", m.display()));
    }
    let params = settings::parameters(file, &overrides)?;
    if args.print_params {
        let full = if namespace == "/" {
            format!("/{name}")
        } else {
            format!("{namespace}/{name}")
        };
        let mut inner = Mapping::new();
        inner.insert("ros__parameters".into(), serde_yaml_ng::to_value(&params)?);
        let mut top = Mapping::new();
        top.insert(full.into(), inner.into());
        print!("{}", serde_yaml_ng::to_string(&top)?);
        return Ok(());
    }
    let topics = settings::topics(&remaps)?;
    let domain_id = match args.domain_id {
        Some(d) => d,
        None => match std::env::var("ROS_DOMAIN_ID") {
            Ok(v) if !v.is_empty() => v.parse().with_context(|| format!("ROS_DOMAIN_ID '{v}'"))?,
            _ => 0,
        },
    };
    cliff_ros2::node::run(
        Settings {
            name,
            namespace,
            params,
            topics,
        },
        domain_id,
    )
}

trait CommandWithHelp {
    fn command_with_help() -> clap::Command;
}

impl CommandWithHelp for Args {
    fn command_with_help() -> clap::Command {
        <Args as clap::CommandFactory>::command().after_help(after_help())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_parameter_has_a_help_line() {
        let v = serde_yaml_ng::to_value(Parameters::default()).unwrap();
        let keys: Vec<String> = v
            .as_mapping()
            .unwrap()
            .keys()
            .map(|k| k.as_str().unwrap().to_string())
            .collect();
        let helped: Vec<&str> = PARAM_HELP.iter().map(|(n, _)| *n).collect();
        assert_eq!(keys, helped);
    }
}
