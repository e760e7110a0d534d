//! The built-in motion model: `builtin.motion` beside this file, compiled in.
//!
//! It is fitted on the open data beside the project by the command in `cliff motion
//! fit --help` ("The built-in model"); `tests/motion_model.rs` fits it again from the
//! same tracks and compares the bytes.

use std::sync::OnceLock;

use super::model::MotionModel;

/// The built-in model's file bytes.
pub const BUILTIN_MOTION_BYTES: &[u8] = include_bytes!("builtin.motion");

impl MotionModel {
    /// The built-in model, fitted on ATC's training hours (13,400 people crossing a
    /// shopping-mall hall, tracked at 1 Hz; `cliff motion fit --help` shows the command
    /// that reproduces it). It knows people who walk on through an open hall: in a room
    /// where people stop and turn within seconds (THÖR-MAGNI's) it does worse than
    /// constant velocity, and a model fitted on the site's own tracks does better
    /// (docs/motion.md).
    pub fn builtin() -> &'static MotionModel {
        static MODEL: OnceLock<MotionModel> = OnceLock::new();
        MODEL.get_or_init(|| {
            MotionModel::decode(BUILTIN_MOTION_BYTES, "the built-in motion model")
                .expect("the built-in motion model is checked by its test")
        })
    }
}
