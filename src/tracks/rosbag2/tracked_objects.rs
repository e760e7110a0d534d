//! `autoware_perception_msgs/msg/TrackedObjects` (autoware_msgs 1.12.0): what
//! Autoware's multi-object tracker publishes (on
//! `/perception/object_recognition/tracking/objects`). The pedestrians are read, as the
//! ROS 2 node `cliff-ros2` reads them live:
//!
//! - an object is a pedestrian when its most probable classification (the first of
//!   equally probable ones) has label 7 (`PEDESTRIAN`); objects without a
//!   classification and every other object are left out;
//! - its track id is `object_id.uuid`, the 16 bytes as 32 lowercase hex digits;
//! - its position is `kinematics.pose_with_covariance.pose.position` x and y, at the
//!   header's stamp;
//! - its speed and motion angle come from the positions (as a CSV without velocity
//!   columns gives them, [`columns`](crate::tracks::columns)): the tracker's twist is in
//!   the object's own frame, and the node does not use it either.
//!
//! ```text
//! std_msgs/Header header
//! TrackedObject[] objects
//!   unique_identifier_msgs/UUID object_id        # uint8[16] uuid
//!   float32 existence_probability
//!   ObjectClassification[] classification       # uint8 label, float32 probability
//!   TrackedObjectKinematics kinematics
//!     geometry_msgs/PoseWithCovariance pose_with_covariance     # pose (position, orientation), float64[36]
//!     geometry_msgs/TwistWithCovariance twist_with_covariance   # twist (linear, angular), float64[36]
//!     geometry_msgs/AccelWithCovariance acceleration_with_covariance
//!     uint8 orientation_availability
//!     bool is_stationary
//!   Shape shape                                  # uint8 type, Polygon footprint (Point32[]), Vector3 dimensions
//! ```

use std::borrow::Cow;
use std::fmt::Write;

use glam::DVec2;

use super::cdr::Cdr;
use super::header::{FieldError, Seen, at, check, header, point};

/// The type's name in a recording.
pub(crate) const NAME: &str = "autoware_perception_msgs/msg/TrackedObjects";

/// `ObjectClassification.PEDESTRIAN`.
pub const PEDESTRIAN: u8 = 7;

/// Fewest bytes a `TrackedObject` takes (its fixed fields: the uuid, two float32, 127
/// float64, three uint8, two empty arrays), to bound the count of objects.
const MIN_OBJECT_BYTES: usize = 16 + 4 + 4 + 127 * 8 + 3 + 4;

/// Decode a `TrackedObjects` message: its time, and its pedestrians appended to `out`
/// (with zero velocity: speeds come from the positions).
pub(crate) fn decode<'a>(bytes: &'a [u8], out: &mut Vec<Seen<'a>>) -> Result<f64, FieldError> {
    let mut r = at(Cdr::new(bytes), || "(encapsulation)".into())?;
    let t = header(&mut r, "header")?;
    let n = at(r.count(MIN_OBJECT_BYTES), || "objects".into())?;
    for i in 0..n {
        let uuid = at(r.bytes::<16>(), || format!("objects[{i}].object_id.uuid"))?;
        at(r.f32(), || format!("objects[{i}].existence_probability"))?;
        let m = at(r.count(5), || format!("objects[{i}].classification"))?;
        // the first of the most probable entries
        let mut best: Option<(u8, f32)> = None;
        for j in 0..m {
            let label = at(r.u8(), || format!("objects[{i}].classification[{j}].label"))?;
            let p = at(r.f32(), || {
                format!("objects[{i}].classification[{j}].probability")
            })?;
            if best.is_none_or(|(_, b)| p > b) {
                best = Some((label, p));
            }
        }
        let k = || format!("objects[{i}].kinematics");
        let pose = || format!("{}.pose_with_covariance.pose", k());
        let position = point(&mut r, &|| format!("{}.position", pose()))?;
        for (what, values) in [
            ("pose_with_covariance.pose.orientation", 4),
            ("pose_with_covariance.covariance", 36),
            ("twist_with_covariance.twist", 6),
            ("twist_with_covariance.covariance", 36),
            ("acceleration_with_covariance.accel", 6),
            ("acceleration_with_covariance.covariance", 36),
        ] {
            for _ in 0..values {
                at(r.f64(), || format!("{}.{what}", k()))?;
            }
        }
        at(r.u8(), || format!("{}.orientation_availability", k()))?;
        at(r.u8(), || format!("{}.is_stationary", k()))?;
        at(r.u8(), || format!("objects[{i}].shape.type"))?;
        let points = at(r.count(12), || {
            format!("objects[{i}].shape.footprint.points")
        })?;
        for j in 0..points {
            for _ in 0..3 {
                at(r.f32(), || {
                    format!("objects[{i}].shape.footprint.points[{j}]")
                })?;
            }
        }
        point(&mut r, &|| format!("objects[{i}].shape.dimensions"))?;
        if best.is_none_or(|(label, _)| label != PEDESTRIAN) {
            continue;
        }
        let mut id = String::with_capacity(32);
        for b in uuid {
            let _ = write!(id, "{b:02x}");
        }
        let seen = Seen {
            id: Cow::Owned(id),
            position,
            velocity: DVec2::ZERO,
        };
        check(&seen, &|| format!("{}.position", pose()), &k)?;
        out.push(seen);
    }
    Ok(t)
}
