//! Evaluation protocols: which people are evaluated, from which start state, for how long.
//!
//! * [`Protocol::Reference`]: exactly what the published CLiFF-LHMP code does (row based:
//!   observe `n` rows, start at row `n`, horizon floored to whole seconds, 10-row idle
//!   filter). Used for parity on THÖR and comparison with the paper.
//! * [`Protocol::Seconds`]: the same ideas stated in time, for data at any rate.
//! * [`Protocol::Windows`]: the seconds rules applied to windows along long recordings
//!   (see [`windows`](crate::eval::windows)); [`prepare_all`] gives every window.
//! * [`Protocol::Tracklets`]: the THÖR-MAGNI benchmark's back-to-back tracklets
//!   ([`tracklets`]); [`prepare_all`] gives every tracklet.
//!
//! See `../shared/docs/evaluation-protocol.md` for the rules.
//!
//! | file | what it holds |
//! |---|---|
//! | [`settings`] | [`Protocol`], [`Settings`] |
//! | [`case`] | [`Case`]: one person (or window) cut into history, start state and truth |
//! | [`prepare`](mod@prepare) | [`prepare`], [`prepare_all`]: the protocol chosen by the settings |
//! | `reference` | the published code's row-based rules |
//! | `seconds` | the same rules stated in time |
//! | [`tracklets`] | the benchmark's tracklets |
//!
//! The windows along long recordings are in [`crate::eval::windows`].

pub mod case;
pub mod prepare;
mod reference;
pub(crate) mod seconds;
pub mod settings;
pub mod tracklets;

pub use case::Case;
pub use prepare::{prepare, prepare_all};
pub use settings::{Protocol, REFERENCE_IDLE_ROWS, Settings};
