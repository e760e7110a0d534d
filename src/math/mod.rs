//! Math the other layers share: angle wrapping (public), and the prediction loop's fast
//! kernels (`fastmath`: sin/cos, acos, exp, atan2 in double and single precision that
//! give the same bits on every machine of one [`Simd`] path; `f32x4`: four
//! single-precision lanes), and the choice of instructions the loop runs on ([`Simd`]).
//!
//! | file | what it holds |
//! |---|---|
//! | [`angle`] | [`wrap_2pi`], [`wrap_pi`] |
//! | `fastmath` | branch-light sin/cos, acos, exp, atan2 |
//! | `f32x4` | a four-lane f32 vector for the density and follow kernels |
//! | `lane_rng` | a generator per sample (xoshiro128++), uniform and normal draws from its words, scalar and AVX2 |
//! | [`simd`] | [`Simd`]: the baseline or AVX2 + FMA, detected at run time (`CLIFF_SIMD`) |

pub mod angle;
pub(crate) mod f32x4;
pub(crate) mod fastmath;
pub(crate) mod lane_rng;
pub mod simd;

pub use angle::{wrap_2pi, wrap_pi};
pub use simd::Simd;
