//! Motion model files (`.motion`): the model's coefficients and spreads behind the
//! checksummed header map snapshots use (magic `CLIFFMOT`, format version, payload
//! length, CRC-32; postcard payload). A file whose header, checksum or values do not
//! hold is refused whole, with an error naming the file and what is wrong.
//!
//! ```
//! use cliff::motion::MotionModel;
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("walk.motion");
//! MotionModel::builtin().save(&path).unwrap();
//! assert_eq!(&MotionModel::load(&path).unwrap(), MotionModel::builtin());
//! std::fs::write(&path, b"not a model").unwrap();
//! let e = MotionModel::load(&path).unwrap_err().to_string();
//! assert!(e.contains("walk.motion") && e.contains("shorter than the 24-byte header"), "{e}");
//! ```

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::history::{HISTORY_POINTS, MODEL_DT};
use super::model::{FEATURES, ModelInfo, MotionModel};
use super::network::Network;
use crate::bounded_read::read_at_most;
use crate::framed::{decode_all, frame, unframe};

/// The first eight bytes of every motion model file.
pub const MOTION_MAGIC: [u8; 8] = *b"CLIFFMOT";
/// The format version this build writes (it also reads version 1: models without a
/// network).
pub const MOTION_VERSION: u32 = 2;
/// Largest motion model file read (bytes); a model of the most steps and the largest
/// network is about 420 KB.
pub const MAX_MOTION_FILE_BYTES: u64 = 1 << 20;

/// A motion model file that could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum MotionError {
    /// Reading or writing failed.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is damaged, of another format, or holds values that are no model.
    #[error("{file}: not a valid cliff motion model: {message}")]
    Format {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
}

/// Version 1's payload: a linear model.
#[derive(Serialize, Deserialize)]
struct Payload {
    dt: f64,
    history_points: u32,
    weights: Vec<[[f64; FEATURES]; 2]>,
    covariance: Vec<[f64; 3]>,
    info: ModelInfo,
}

/// Version 2's payload: version 1's and the network, if any.
#[derive(Serialize, Deserialize)]
struct PayloadV2 {
    linear: Payload,
    network: Option<Network>,
}

impl MotionModel {
    /// The model as file bytes.
    pub fn encode(&self) -> Vec<u8> {
        let payload = PayloadV2 {
            linear: Payload {
                dt: MODEL_DT,
                history_points: HISTORY_POINTS as u32,
                weights: self.weights().to_vec(),
                covariance: self.covariance().to_vec(),
                info: self.info().clone(),
            },
            network: self.network().cloned(),
        };
        let body =
            postcard::to_stdvec(&payload).expect("serialising plain data to memory cannot fail");
        frame(&MOTION_MAGIC, MOTION_VERSION, &body)
    }

    /// A model from file bytes; `file` names the source in errors.
    pub fn decode(bytes: &[u8], file: &str) -> Result<Self, MotionError> {
        let bad = |message: String| MotionError::Format {
            file: file.to_string(),
            message,
        };
        let (version, body) = unframe(
            bytes,
            &MOTION_MAGIC,
            "a cliff motion model",
            &[1, MOTION_VERSION],
        )
        .map_err(bad)?;
        let PayloadV2 { linear: p, network } = if version == 1 {
            PayloadV2 {
                linear: decode_all(body, "payload").map_err(bad)?,
                network: None,
            }
        } else {
            decode_all(body, "payload").map_err(bad)?
        };
        if p.dt != MODEL_DT || p.history_points as usize != HISTORY_POINTS {
            return Err(bad(format!(
                "a model of {} history points at {} s, this build reads {HISTORY_POINTS} at {MODEL_DT} s",
                p.history_points, p.dt
            )));
        }
        let model =
            MotionModel::new(p.weights, p.covariance, p.info).map_err(|e| bad(e.to_string()))?;
        match network {
            Some(n) => model.with_network(n).map_err(|e| bad(e.to_string())),
            None => Ok(model),
        }
    }

    /// Read a model file (at most [`MAX_MOTION_FILE_BYTES`]).
    pub fn load(path: &Path) -> Result<Self, MotionError> {
        let name = path.display().to_string();
        let bytes =
            read_at_most(path, MAX_MOTION_FILE_BYTES).map_err(|source| MotionError::Io {
                file: name.clone(),
                source,
            })?;
        Self::decode(&bytes, &name)
    }

    /// Write the model to a file.
    pub fn save(&self, path: &Path) -> Result<(), MotionError> {
        std::fs::write(path, self.encode()).map_err(|source| MotionError::Io {
            file: path.display().to_string(),
            source,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::network::INPUTS;

    #[test]
    fn a_model_with_a_network_is_written_and_read_whole() {
        let steps = MotionModel::builtin().steps();
        let net = Network {
            hidden: 4,
            outputs: 2 * steps,
            mean: [0.5; INPUTS],
            scale: [2.0; INPUTS],
            w1: (0..INPUTS * 4).map(|i| i as f32 * 0.01).collect(),
            b1: vec![0.1; 4],
            w2: vec![-0.2; 16],
            b2: vec![0.3; 4],
            w3: (0..4 * 2 * steps).map(|i| (i % 7) as f32 * 0.01).collect(),
            b3: vec![0.01; 2 * steps],
        };
        let model = MotionModel::builtin().clone().with_network(net).unwrap();
        let back = MotionModel::decode(&model.encode(), "m").unwrap();
        assert_eq!(back, model);
        assert!(back.network().is_some());
        // the network's shape is checked on reading too
        let mut bad = model.network().unwrap().clone();
        bad.outputs = 2;
        let body = postcard::to_stdvec(&PayloadV2 {
            linear: Payload {
                dt: MODEL_DT,
                history_points: HISTORY_POINTS as u32,
                weights: model.weights().to_vec(),
                covariance: model.covariance().to_vec(),
                info: model.info().clone(),
            },
            network: Some(bad),
        })
        .unwrap();
        let e = MotionModel::decode(&frame(&MOTION_MAGIC, MOTION_VERSION, &body), "n.motion")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("n.motion: not a valid cliff motion model: the network gives 2 outputs"),
            "{e}"
        );
    }

    #[test]
    fn damaged_files_are_refused_with_what_is_wrong() {
        let bytes = MotionModel::builtin().encode();
        let back = MotionModel::decode(&bytes, "m").unwrap();
        assert_eq!(&back, MotionModel::builtin());
        let mut flipped = bytes.clone();
        flipped[40] ^= 0x10;
        let e = MotionModel::decode(&flipped, "m.motion")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("m.motion: not a valid cliff motion model: checksum"),
            "{e}"
        );
        let mut map = bytes.clone();
        map[..8].copy_from_slice(b"CLIFFMAP");
        let e = MotionModel::decode(&map, "m").unwrap_err().to_string();
        assert!(e.contains("not a cliff motion model"), "{e}");
        // a payload of values that are no model: the header is right, the values are not
        let model = MotionModel::builtin();
        let mut cov = model.covariance().to_vec();
        cov[0] = [-1.0, 0.0, 1.0];
        let body = postcard::to_stdvec(&Payload {
            dt: MODEL_DT,
            history_points: HISTORY_POINTS as u32,
            weights: model.weights().to_vec(),
            covariance: cov,
            info: model.info().clone(),
        })
        .unwrap();
        let e = MotionModel::decode(&frame(&MOTION_MAGIC, 1, &body), "m")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("step 1") && e.contains("not a covariance"),
            "{e}"
        );
        // a version 1 file (a linear model) reads as it did
        let linear = postcard::to_stdvec(&Payload {
            dt: MODEL_DT,
            history_points: HISTORY_POINTS as u32,
            weights: model.weights().to_vec(),
            covariance: model.covariance().to_vec(),
            info: model.info().clone(),
        })
        .unwrap();
        let v1 = MotionModel::decode(&frame(&MOTION_MAGIC, 1, &linear), "m").unwrap();
        assert_eq!(&v1, model);
        let e = MotionModel::load(Path::new("/nonexistent/walk.motion")).unwrap_err();
        assert!(
            e.to_string().starts_with("/nonexistent/walk.motion: "),
            "{e}"
        );
    }
}
