//! Math the other layers share: angle wrapping (public), and the prediction loop's fast
//! kernels (`fastmath`: sin/cos, acos, exp, atan2 in double and single precision that
//! give the same bits on every machine; `f32x4`: four single-precision lanes).
//!
//! | file | what it holds |
//! |---|---|
//! | [`angle`] | [`wrap_2pi`], [`wrap_pi`] |
//! | `fastmath` | branch-light sin/cos, acos, exp, atan2 |
//! | `f32x4` | a four-lane f32 vector for the density and follow kernels |

pub mod angle;
pub(crate) mod f32x4;
pub(crate) mod fastmath;

pub use angle::{wrap_2pi, wrap_pi};
