//! Golden CDR bytes: every message type cliff-ros2 reads or writes, built from
//! `tests/golden/samples.json` into our serde structs and serialized the way the node's
//! publishers do (RustDDS's little-endian CDR adapter, through ros2-client), must give
//! exactly the bytes the independent `rosbags` serializer wrote for the same values
//! (`tests/golden/make_golden.py`; `.ci/ros2` re-runs it with `--check`). The inputs
//! must also decode from those bytes to the same values.

use std::path::PathBuf;

use cliff_ros2::msg::{
    Header, Marker, MarkerArray, OccupancyGrid, People, PersonPrediction, Point2, PredictedObjects,
    PredictedPath, Predictions, Shape, Time, TrackedObjects,
};
use ros2_client::dds::rustdds::no_key::{DeserializerAdapter, SerializerAdapter};
use ros2_client::dds::rustdds::{
    CDRDeserializerAdapter, CDRSerializerAdapter, RepresentationIdentifier,
};
use serde::Serialize;
use serde::de::DeserializeOwned;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

fn samples() -> serde_json::Map<String, serde_json::Value> {
    let text = std::fs::read_to_string(dir().join("samples.json")).expect("samples.json");
    serde_json::from_str(&text).expect("samples.json is a JSON object")
}

/// The golden file of `type_name`: encapsulation header (CDR little endian, no options)
/// and body.
fn golden(type_name: &str) -> Vec<u8> {
    let path = dir().join(format!("{}.cdr", type_name.replace('/', "__")));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Our bytes of `type_name`'s sample equal the golden ones; returns the value.
fn check<T>(type_name: &str) -> T
where
    T: Serialize + DeserializeOwned + PartialEq + std::fmt::Debug,
{
    let all = samples();
    let json = all
        .get(type_name)
        .unwrap_or_else(|| panic!("{type_name} has no sample"));
    let value: T = serde_json::from_value(json.clone())
        .unwrap_or_else(|e| panic!("{type_name}: sample does not fit our struct: {e}"));
    let golden = golden(type_name);
    assert_eq!(
        &golden[..4],
        &[0x00, 0x01, 0x00, 0x00],
        "{type_name}: CDR_LE header"
    );
    assert_eq!(
        CDRSerializerAdapter::<T>::output_encoding(),
        RepresentationIdentifier::CDR_LE
    );
    let ours = CDRSerializerAdapter::<T>::to_bytes(&value).expect("serializes");
    assert_eq!(
        hex(&ours),
        hex(&golden[4..]),
        "{type_name}: our CDR body differs from rosbags'"
    );
    let back: T =
        CDRDeserializerAdapter::<T>::from_bytes(&golden[4..], RepresentationIdentifier::CDR_LE)
            .unwrap_or_else(|e| panic!("{type_name}: decoding the golden bytes: {e:?}"));
    assert_eq!(back, value, "{type_name}: decoded golden bytes");
    value
}

fn hex(b: &[u8]) -> String {
    b.chunks(16)
        .map(|c| {
            c.iter()
                .map(|x| format!("{x:02x}"))
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn time_and_header_bytes_equal_rosbags() {
    let t: Time = check("builtin_interfaces/msg/Time");
    assert_eq!(t.sec, -3);
    let h: Header = check("std_msgs/msg/Header");
    assert_eq!(h.frame_id, "odom_x");
}

#[test]
fn people_bytes_equal_rosbags() {
    let p: People = check("people_msgs/msg/People");
    assert_eq!(p.people.len(), 2);
}

#[test]
fn tracked_objects_bytes_equal_rosbags() {
    let o: TrackedObjects = check("autoware_perception_msgs/msg/TrackedObjects");
    assert!(o.objects[0].is_pedestrian() && !o.objects[1].is_pedestrian());
    assert_eq!(
        &o.objects[0].object_id.hex(),
        b"00112233445566778899aabbccddeeff"
    );
}

#[test]
fn predictions_bytes_equal_rosbags() {
    check::<Point2>("cliff_msgs/msg/Point2");
    check::<PersonPrediction>("cliff_msgs/msg/PersonPrediction");
    let p: Predictions = check("cliff_msgs/msg/Predictions");
    assert_eq!(p.people.len(), 2);
}

#[test]
fn marker_bytes_equal_rosbags() {
    let m: Marker = check("visualization_msgs/msg/Marker");
    assert_eq!(m.type_, Marker::LINE_STRIP);
    let a: MarkerArray = check("visualization_msgs/msg/MarkerArray");
    assert_eq!(a.markers[1].action, Marker::DELETE);
}

#[test]
fn predicted_objects_bytes_equal_rosbags() {
    let p: PredictedPath = check("autoware_perception_msgs/msg/PredictedPath");
    assert_eq!((p.path.len(), p.time_step.nanosec), (3, 400_000_000));
    let o: PredictedObjects = check("autoware_perception_msgs/msg/PredictedObjects");
    assert_eq!(o.objects.len(), 2);
    assert_eq!(o.objects[0].shape.type_, Shape::CYLINDER);
    assert_eq!(o.objects[0].kinematics.predicted_paths.len(), 2);
    assert!(o.objects[1].kinematics.predicted_paths.is_empty());
}

#[test]
fn occupancy_grid_bytes_equal_rosbags() {
    let g: OccupancyGrid = check("nav_msgs/msg/OccupancyGrid");
    assert_eq!((g.info.width, g.info.height), (3, 2));
    assert_eq!(g.data, [0, 100, -1, 37, 5, 0]);
}

#[test]
fn every_sample_is_checked() {
    let names: Vec<String> = samples().keys().cloned().collect();
    let tested = [
        "builtin_interfaces/msg/Time",
        "std_msgs/msg/Header",
        "people_msgs/msg/People",
        "autoware_perception_msgs/msg/TrackedObjects",
        "autoware_perception_msgs/msg/PredictedPath",
        "autoware_perception_msgs/msg/PredictedObjects",
        "cliff_msgs/msg/Point2",
        "cliff_msgs/msg/PersonPrediction",
        "cliff_msgs/msg/Predictions",
        "visualization_msgs/msg/Marker",
        "visualization_msgs/msg/MarkerArray",
        "nav_msgs/msg/OccupancyGrid",
    ];
    let mut a = names.clone();
    a.sort();
    let mut b: Vec<String> = tested.iter().map(|s| s.to_string()).collect();
    b.sort();
    assert_eq!(a, b);
}
