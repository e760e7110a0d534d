//! The ROS 2 messages the node reads and writes, as plain serde structs: field order
//! and types follow the `.msg` definitions exactly, which is all RustDDS's CDR
//! serializer needs (no generated code). Jazzy's definitions.

use serde::{Deserialize, Serialize};

/// A DDS type name: `(package, type)`, e.g. `("people_msgs", "People")`.
pub type TypeName = (&'static str, &'static str);

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second (`0..1e9`).
    pub nanosec: u32,
}

impl Time {
    /// Seconds as `f64`.
    pub fn as_secs_f64(self) -> f64 {
        self.sec as f64 + self.nanosec as f64 * 1e-9
    }

    /// The stamp of `t` seconds, rounded to the nanosecond (saturating outside the `i32`
    /// range; NaN gives 0).
    pub fn from_secs_f64(t: f64) -> Time {
        if !t.is_finite() {
            return Time::default();
        }
        let mut sec = t.floor();
        let mut ns = ((t - sec) * 1e9).round();
        if ns >= 1e9 {
            sec += 1.0;
            ns -= 1e9;
        }
        if sec < i32::MIN as f64 {
            return Time {
                sec: i32::MIN,
                nanosec: 0,
            };
        }
        if sec > i32::MAX as f64 {
            return Time {
                sec: i32::MAX,
                nanosec: 999_999_999,
            };
        }
        Time {
            sec: sec as i32,
            nanosec: ns as u32,
        }
    }
}

/// `builtin_interfaces/msg/Duration`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Duration {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds.
    pub nanosec: u32,
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// When the data was observed.
    pub stamp: Time,
    /// The coordinate frame of the data.
    pub frame_id: String,
}

/// `std_msgs/msg/ColorRGBA`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct ColorRGBA {
    /// Red, 0..1.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Opacity.
    pub a: f32,
}

/// `geometry_msgs/msg/Point`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m).
    pub z: f64,
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    /// The identity (as ROS 2's default-constructed message).
    fn default() -> Self {
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

impl Quaternion {
    /// A rotation by `yaw` (rad) about z.
    pub fn from_yaw(yaw: f64) -> Self {
        let (s, c) = (yaw * 0.5).sin_cos();
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: s,
            w: c,
        }
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `people_msgs/msg/Person` (wg-perception/people, ROS 2 branch).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Person {
    /// The tracker's id of the person: our track id.
    pub name: String,
    /// Position (m) in the header's frame.
    pub position: Point,
    /// Velocity (m/s); not used (trackers often leave it zero): the velocity is
    /// estimated from the positions, as the daemon does.
    pub velocity: Point,
    /// Tracker confidence.
    pub reliability: f64,
    /// Tag names.
    pub tagnames: Vec<String>,
    /// Tag values.
    pub tags: Vec<String>,
}

/// `people_msgs/msg/People`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct People {
    /// Stamp and frame of every person.
    pub header: Header,
    /// The people.
    pub people: Vec<Person>,
}

/// The DDS type of [`People`].
pub const PEOPLE: TypeName = ("people_msgs", "People");

/// `sensor_msgs/msg/CompressedImage` (inside [`Marker`] since Jazzy).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Header.
    pub header: Header,
    /// Format.
    pub format: String,
    /// Bytes.
    pub data: Vec<u8>,
}

/// `visualization_msgs/msg/UVCoordinate`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct UVCoordinate {
    /// u.
    pub u: f32,
    /// v.
    pub v: f32,
}

/// `visualization_msgs/msg/MeshFile`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshFile {
    /// File name.
    pub filename: String,
    /// Bytes.
    pub data: Vec<u8>,
}

/// `visualization_msgs/msg/Marker` (Jazzy: with the texture and mesh-file fields).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    /// Frame and stamp.
    pub header: Header,
    /// Namespace: with `id`, the marker's identity.
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// [`Marker::ARROW`], [`Marker::LINE_STRIP`], ...
    #[serde(rename = "type")]
    pub type_: i32,
    /// [`Marker::ADD`], [`Marker::DELETE`], [`Marker::DELETEALL`].
    pub action: i32,
    /// Pose.
    pub pose: Pose,
    /// Scale (a line strip's width is `scale.x`).
    pub scale: Vector3,
    /// Colour (of the whole marker unless `colors` is given).
    pub color: ColorRGBA,
    /// How long the marker stays shown (0: until replaced or deleted).
    pub lifetime: Duration,
    /// Re-transform every frame.
    pub frame_locked: bool,
    /// Points (line strips, lists).
    pub points: Vec<Point>,
    /// Per-point colours.
    pub colors: Vec<ColorRGBA>,
    /// Texture (Jazzy).
    pub texture_resource: String,
    /// Texture image (Jazzy).
    pub texture: CompressedImage,
    /// Texture coordinates (Jazzy).
    pub uv_coordinates: Vec<UVCoordinate>,
    /// Text.
    pub text: String,
    /// Mesh resource.
    pub mesh_resource: String,
    /// Embedded mesh file (Jazzy).
    pub mesh_file: MeshFile,
    /// Use the mesh's materials.
    pub mesh_use_embedded_materials: bool,
}

impl Marker {
    /// Arrow.
    pub const ARROW: i32 = 0;
    /// Line strip.
    pub const LINE_STRIP: i32 = 4;
    /// Add or modify.
    pub const ADD: i32 = 0;
    /// Delete this marker.
    pub const DELETE: i32 = 2;
    /// Delete every marker (of this namespace, since Humble).
    pub const DELETEALL: i32 = 3;
}

/// `visualization_msgs/msg/MarkerArray`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MarkerArray {
    /// Markers.
    pub markers: Vec<Marker>,
}

/// The DDS type of [`MarkerArray`].
pub const MARKER_ARRAY: TypeName = ("visualization_msgs", "MarkerArray");

/// `cliff_msgs/msg/Point2`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Point2 {
    /// x (m).
    pub x: f32,
    /// y (m).
    pub y: f32,
}

/// `cliff_msgs/msg/PersonPrediction`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PersonPrediction {
    /// The tracker's id.
    pub track_id: String,
    /// Time of the last observation.
    pub stamp: Time,
    /// Observations predicted from.
    pub history: u32,
    /// Last observed position.
    pub origin: Point2,
    /// Points per sample.
    pub lengths: Vec<u32>,
    /// The samples' points, one sample after the other.
    pub points: Vec<Point2>,
    /// One score per sample, or empty.
    pub scores: Vec<f32>,
}

/// `cliff_msgs/msg/Predictions`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Predictions {
    /// Newest input stamp and the map frame.
    pub header: Header,
    /// Seconds between points.
    pub dt: f64,
    /// Horizon (s).
    pub horizon: f64,
    /// Samples per person.
    pub k: u32,
    /// Method name.
    pub method: String,
    /// Map name or file.
    pub map: String,
    /// Seed.
    pub seed: u64,
    /// One per predicted person.
    pub people: Vec<PersonPrediction>,
}

/// The DDS type of [`Predictions`].
pub const PREDICTIONS: TypeName = ("cliff_msgs", "Predictions");

/// A row-major 6×6 covariance (`float64[36]`: a CDR fixed array, no length).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Covariance(pub [f64; 36]);

impl Default for Covariance {
    fn default() -> Self {
        Covariance([0.0; 36])
    }
}

impl Serialize for Covariance {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple;
        let mut t = s.serialize_tuple(36)?;
        for v in &self.0 {
            t.serialize_element(v)?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for Covariance {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Covariance;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("36 float64 values")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut a: A,
            ) -> Result<Covariance, A::Error> {
                let mut c = [0.0; 36];
                for (i, v) in c.iter_mut().enumerate() {
                    *v = a
                        .next_element()?
                        .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                Ok(Covariance(c))
            }
        }
        d.deserialize_tuple(36, V)
    }
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// Pose.
    pub pose: Pose,
    /// Covariance of (x, y, z, rot x, rot y, rot z).
    pub covariance: Covariance,
}

/// `geometry_msgs/msg/Twist` (and `Accel`: the same fields).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear part.
    pub linear: Vector3,
    /// Angular part.
    pub angular: Vector3,
}

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// Twist.
    pub twist: Twist,
    /// Covariance.
    pub covariance: Covariance,
}

/// `geometry_msgs/msg/AccelWithCovariance`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct AccelWithCovariance {
    /// Acceleration (`geometry_msgs/Accel`: linear and angular, as a twist).
    pub accel: Twist,
    /// Covariance.
    pub covariance: Covariance,
}

/// `geometry_msgs/msg/Point32`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Point32 {
    /// x.
    pub x: f32,
    /// y.
    pub y: f32,
    /// z.
    pub z: f32,
}

/// `geometry_msgs/msg/Polygon`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Polygon {
    /// Corners.
    pub points: Vec<Point32>,
}

/// `unique_identifier_msgs/msg/UUID`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Uuid {
    /// The 16 bytes (a CDR fixed array).
    pub uuid: [u8; 16],
}

impl Uuid {
    /// The 16 bytes as 32 lowercase hex digits, in array order (the track id).
    pub fn hex(&self) -> [u8; 32] {
        const DIGITS: &[u8; 16] = b"0123456789abcdef";
        let mut out = [0u8; 32];
        for (i, b) in self.uuid.iter().enumerate() {
            out[2 * i] = DIGITS[(b >> 4) as usize];
            out[2 * i + 1] = DIGITS[(b & 15) as usize];
        }
        out
    }
}

/// `autoware_perception_msgs/msg/ObjectClassification` (autoware_msgs 1.12.0).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectClassification {
    /// Class label ([`ObjectClassification::PEDESTRIAN`], ...).
    pub label: u8,
    /// Probability of the label, 0..1.
    pub probability: f32,
}

impl ObjectClassification {
    /// The pedestrian label.
    pub const PEDESTRIAN: u8 = 7;
}

/// `autoware_perception_msgs/msg/TrackedObjectKinematics`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TrackedObjectKinematics {
    /// Pose (the position is used).
    pub pose_with_covariance: PoseWithCovariance,
    /// Velocity.
    pub twist_with_covariance: TwistWithCovariance,
    /// Acceleration.
    pub acceleration_with_covariance: AccelWithCovariance,
    /// UNAVAILABLE 0, SIGN_UNKNOWN 1, AVAILABLE 2.
    pub orientation_availability: u8,
    /// Not moving.
    pub is_stationary: bool,
}

/// `autoware_perception_msgs/msg/Shape`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Shape {
    /// BOUNDING_BOX 0, CYLINDER 1, POLYGON 2.
    #[serde(rename = "type")]
    pub type_: u8,
    /// Footprint (polygons).
    pub footprint: Polygon,
    /// Dimensions (m).
    pub dimensions: Vector3,
}

impl Shape {
    /// An upright cylinder: `dimensions` x and y the diameter, z the height.
    pub const CYLINDER: u8 = 1;
}

/// `autoware_perception_msgs/msg/TrackedObject`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TrackedObject {
    /// The tracker's id: our track id is its hex form ([`Uuid::hex`]).
    pub object_id: Uuid,
    /// Existence probability.
    pub existence_probability: f32,
    /// Class probabilities: a pedestrian when the most probable label is 7.
    pub classification: Vec<ObjectClassification>,
    /// Pose, twist, acceleration.
    pub kinematics: TrackedObjectKinematics,
    /// Shape.
    pub shape: Shape,
}

impl TrackedObject {
    /// The most probable label is [`ObjectClassification::PEDESTRIAN`] (the first of
    /// equally probable entries counts; no entry: not a pedestrian).
    pub fn is_pedestrian(&self) -> bool {
        let mut best: Option<&ObjectClassification> = None;
        for c in &self.classification {
            if best.is_none_or(|b| c.probability > b.probability) {
                best = Some(c);
            }
        }
        best.is_some_and(|c| c.label == ObjectClassification::PEDESTRIAN)
    }
}

/// `autoware_perception_msgs/msg/TrackedObjects`: Autoware's tracker output.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TrackedObjects {
    /// Stamp and frame of every object.
    pub header: Header,
    /// The objects (pedestrians and others).
    pub objects: Vec<TrackedObject>,
}

/// The DDS type of [`TrackedObjects`].
pub const TRACKED_OBJECTS: TypeName = ("autoware_perception_msgs", "TrackedObjects");

/// `autoware_perception_msgs/msg/PredictedPath`: one predicted path of an object.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PredictedPath {
    /// Poses `time_step` apart, the first at the header's stamp.
    pub path: Vec<Pose>,
    /// Time between two poses.
    pub time_step: Duration,
    /// Confidence of the path, 0..1.
    pub confidence: f32,
}

/// `autoware_perception_msgs/msg/PredictedObjectKinematics`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PredictedObjectKinematics {
    /// Pose now.
    pub initial_pose_with_covariance: PoseWithCovariance,
    /// Velocity now (in the object's frame: `linear.x` forward).
    pub initial_twist_with_covariance: TwistWithCovariance,
    /// Acceleration now.
    pub initial_acceleration_with_covariance: AccelWithCovariance,
    /// The predicted paths.
    pub predicted_paths: Vec<PredictedPath>,
}

/// `autoware_perception_msgs/msg/PredictedObject`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PredictedObject {
    /// The object's id.
    pub object_id: Uuid,
    /// Existence probability, 0..1.
    pub existence_probability: f32,
    /// Class probabilities.
    pub classification: Vec<ObjectClassification>,
    /// Pose, twist, acceleration and the predicted paths.
    pub kinematics: PredictedObjectKinematics,
    /// Shape.
    pub shape: Shape,
}

/// `autoware_perception_msgs/msg/PredictedObjects`: what Autoware's planners read.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PredictedObjects {
    /// Stamp and frame of every object.
    pub header: Header,
    /// The objects.
    pub objects: Vec<PredictedObject>,
}

/// The DDS type of [`PredictedObjects`].
pub const PREDICTED_OBJECTS: TypeName = ("autoware_perception_msgs", "PredictedObjects");

/// `nav_msgs/msg/MapMetaData`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct MapMetaData {
    /// When the map was loaded (the grid's stamp here).
    pub map_load_time: Time,
    /// The side of a cell (m).
    pub resolution: f32,
    /// Cells along x.
    pub width: u32,
    /// Cells along y.
    pub height: u32,
    /// The corner of cell (0, 0) in the frame (rotation: none here).
    pub origin: Pose,
}

/// `nav_msgs/msg/OccupancyGrid`: row-major cells, 0..100 (probability in percent), -1
/// unknown.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    /// Stamp and frame.
    pub header: Header,
    /// Size, resolution and origin.
    pub info: MapMetaData,
    /// The cells, row after row (row 0 at the origin's y).
    pub data: Vec<i8>,
}

/// The DDS type of [`OccupancyGrid`].
pub const OCCUPANCY_GRID: TypeName = ("nav_msgs", "OccupancyGrid");

/// A message shared with a publisher instead of copied: serializes as `T`. The engine
/// keeps the `Arc` and reuses the message once the publisher has written it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Shared<T>(pub std::sync::Arc<T>);

impl<T: Serialize> Serialize for Shared<T> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.0.serialize(s)
    }
}

impl ros2_client::Message for People {}
impl ros2_client::Message for TrackedObjects {}
impl ros2_client::Message for MarkerArray {}
impl ros2_client::Message for Predictions {}
impl ros2_client::Message for PredictedObjects {}
impl ros2_client::Message for OccupancyGrid {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_round_trips_through_seconds() {
        for t in [0.0, 1.5, 1_351_700_000.123_456_7, -0.25, 12.4] {
            let s = Time::from_secs_f64(t);
            assert!(s.nanosec < 1_000_000_000);
            assert!((s.as_secs_f64() - t).abs() < 1e-6, "{t} -> {s:?}");
        }
        assert_eq!(
            Time::from_secs_f64(0.9999999999),
            Time { sec: 1, nanosec: 0 }
        );
        assert_eq!(Time::from_secs_f64(f64::NAN), Time::default());
        assert_eq!(Time::from_secs_f64(1e300).sec, i32::MAX);
    }

    #[test]
    fn uuid_hex_is_the_bytes_in_order() {
        let mut u = Uuid::default();
        for (i, b) in u.uuid.iter_mut().enumerate() {
            *b = (i as u8) * 17;
        }
        assert_eq!(&u.hex(), b"00112233445566778899aabbccddeeff");
    }

    #[test]
    fn pedestrian_is_the_most_probable_label() {
        let c = |label, probability| ObjectClassification { label, probability };
        let o = |cs: Vec<ObjectClassification>| TrackedObject {
            classification: cs,
            ..TrackedObject::default()
        };
        assert!(o(vec![c(7, 0.9)]).is_pedestrian());
        assert!(o(vec![c(1, 0.2), c(7, 0.7), c(6, 0.1)]).is_pedestrian());
        assert!(!o(vec![c(7, 0.3), c(6, 0.7)]).is_pedestrian());
        assert!(o(vec![c(7, 0.5), c(6, 0.5)]).is_pedestrian());
        assert!(!o(vec![c(6, 0.5), c(7, 0.5)]).is_pedestrian());
        assert!(!o(vec![]).is_pedestrian());
    }

    #[test]
    fn yaw_quaternion_is_unit() {
        let q = Quaternion::from_yaw(1.0);
        assert!(((q.z * q.z + q.w * q.w) - 1.0).abs() < 1e-12);
        assert_eq!(Quaternion::default().w, 1.0);
    }
}
