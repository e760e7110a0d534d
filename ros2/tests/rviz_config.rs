//! `ros2/cliff.rviz` shows what the node publishes: its marker displays subscribe to the
//! node's default topics (root namespace) with QoS that matches the publishers (the map
//! latched: transient local), in the map frame.

use cliff_ros2::node::resolve;
use cliff_ros2::settings::{Parameters, TOPICS};
use serde_yaml_ng::Value;

fn topic(key: &str) -> String {
    let (_, name) = TOPICS.iter().find(|(k, _)| *k == key).expect("topic key");
    resolve("/", name)
}

#[test]
fn rviz_config_shows_the_markers_in_the_map_frame() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/cliff.rviz");
    let doc: Value = serde_yaml_ng::from_str(&std::fs::read_to_string(path).expect("cliff.rviz"))
        .expect("cliff.rviz is YAML");
    let vm = &doc["Visualization Manager"];
    assert_eq!(
        vm["Global Options"]["Fixed Frame"].as_str(),
        Some(Parameters::default().map_frame.as_str())
    );
    let displays = vm["Displays"].as_sequence().expect("displays");
    let marker_topic = |t: &str| {
        displays
            .iter()
            .find(|d| {
                d["Class"].as_str() == Some("rviz_default_plugins/MarkerArray")
                    && d["Topic"]["Value"].as_str() == Some(t)
            })
            .unwrap_or_else(|| panic!("no MarkerArray display of {t}"))
    };
    let samples = marker_topic(&topic("markers"));
    assert_eq!(
        samples["Topic"]["Reliability Policy"].as_str(),
        Some("Reliable")
    );
    let map = marker_topic(&topic("map_markers"));
    assert_eq!(
        map["Topic"]["Durability Policy"].as_str(),
        Some("Transient Local")
    );
    for d in [samples, map] {
        assert_eq!(d["Enabled"].as_bool(), Some(true));
    }
}
