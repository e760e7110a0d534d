//! # cliff-ros2: a ROS 2 node for CLiFF-LHMP predictions
//!
//! Tracked people in (`people_msgs/msg/People`, or the pedestrians of Autoware's
//! `autoware_perception_msgs/msg/TrackedObjects`), sampled trajectories out (`cliff_msgs/msg/Predictions`,
//! `visualization_msgs/msg/MarkerArray`), speaking DDS to stock ROS 2 through
//! ros2-client over RustDDS: no ROS installation is needed to build or run it.
//! Predictions come from a running `cliffd` or, with a map file, in-process; the same
//! histories and seed give the same numbers either way.
//!
//! * [`msg`]: the messages as serde structs.
//! * [`tracks`]: the per-track bounded histories (timeouts, caps, frames, bad input).
//! * [`predictor`]: cliffd or in-process.
//! * [`objects`]: the predictions as Autoware's `PredictedObjects`; [`uuid`]: their ids.
//! * [`grid`]: the predictions as an `OccupancyGrid` for Nav2.
//! * [`observer`]: the tracks sent to a daemon that learns its map.
//! * [`engine`]: one cycle, without ROS; [`node`]: the DDS wiring.
//! * [`settings`]: parameters (YAML file, overrides), names, remapping.
#![warn(missing_docs)]

pub mod engine;
pub mod grid;
pub mod markers;
pub mod msg;
pub mod node;
pub mod objects;
pub mod observer;
pub mod predictor;
pub mod settings;
pub mod tracks;
pub mod uuid;
pub mod warn;
