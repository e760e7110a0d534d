//! The request as it travels: its fixed header ([`RequestHeader`]) and the rows of the
//! agents' observed histories ([`Observation`]).

use cliff::predict::{HeadingRule, Options, Params};
use iceoryx2::prelude::ZeroCopySend;

use super::codes::{
    FLAG_SCORES, FLAG_VELOCITY, HEADING_CIRCULAR_MEAN, HEADING_PAPER, KIND_PREDICT, MAP_NAME_BYTES,
    PROTOCOL_VERSION, TIME_NOW, method_code,
};
use super::map_time::MapTime;

/// Fixed part of a request (the iceoryx2 request user header).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("cliff.protocol.v2.RequestHeader")]
#[repr(C)]
pub struct RequestHeader {
    /// Must be [`PROTOCOL_VERSION`].
    pub version: u32,
    /// [`KIND_PREDICT`] or [`KIND_RELOAD`](super::KIND_RELOAD).
    pub kind: u32,
    /// Chosen by the client, echoed in the response.
    pub request_id: u64,
    /// iceoryx2 listener id (low, high 64 bits) the daemon notifies when the response is
    /// sent; `[0, 0]` for none (a busy-polling client).
    pub listener_id: [u64; 2],
    /// Map name, UTF-8, NUL-padded.
    pub map: [u8; MAP_NAME_BYTES],
    /// [`METHOD_CLIFF`](super::METHOD_CLIFF), [`METHOD_CVM`](super::METHOD_CVM) or
    /// [`METHOD_IMPROVED`](super::METHOD_IMPROVED).
    pub method: u32,
    /// [`HEADING_CIRCULAR_MEAN`] or [`HEADING_PAPER`].
    pub heading_rule: u32,
    /// Samples per agent.
    pub k: u32,
    /// Number of agents; the rows hold agents `0..agents`.
    pub agents: u32,
    /// Time step (s).
    pub dt: f64,
    /// Horizon (s); steps = `floor(horizon / dt)`.
    pub horizon: f64,
    /// CLiFF-LHMP kernel parameter.
    pub beta: f64,
    /// Sampling radius (m).
    pub radius: f64,
    /// Seed of the request's random generator.
    pub seed: u64,
    /// Speed kernel parameter ([`Options::speed_beta`]); 0 keeps the observed speed.
    pub speed_beta: f64,
    /// Seconds a sample coasts where the map has no data ([`Options::coast`], at most
    /// the horizon); 0 stops it there.
    pub coast: f64,
    /// Bits: [`FLAG_SCORES`].
    pub flags: u32,
    /// Which map of the time of day: [`TIME_NOW`], [`TIME_AT`](super::TIME_AT) or
    /// [`TIME_ALL_DAY`](super::TIME_ALL_DAY).
    pub time_mode: u32,
    /// For [`TIME_AT`](super::TIME_AT): the time (s on the map's clock); must be finite in every
    /// mode.
    pub time: f64,
}

impl Default for RequestHeader {
    fn default() -> Self {
        RequestHeader::from_params(&Params::default())
    }
}

impl RequestHeader {
    /// A predict header for `params` (map name empty, no agents, no listener).
    pub fn from_params(params: &Params) -> Self {
        RequestHeader {
            version: PROTOCOL_VERSION,
            kind: KIND_PREDICT,
            request_id: 0,
            listener_id: [0, 0],
            map: [0; MAP_NAME_BYTES],
            method: method_code(params.method),
            heading_rule: match params.heading {
                HeadingRule::CircularMean => HEADING_CIRCULAR_MEAN,
                HeadingRule::Paper => HEADING_PAPER,
            },
            k: params.k.min(u32::MAX as usize) as u32,
            agents: 0,
            dt: params.dt,
            horizon: params.horizon,
            beta: params.beta,
            radius: params.radius,
            seed: params.seed,
            speed_beta: 0.0,
            coast: 0.0,
            flags: 0,
            time_mode: TIME_NOW,
            time: 0.0,
        }
    }

    /// Set the options beyond the paper (speed kernel, coasting, scores).
    pub fn set_options(&mut self, options: &Options) {
        self.speed_beta = options.speed_beta;
        self.coast = options.coast;
        self.flags = if options.scores {
            self.flags | FLAG_SCORES
        } else {
            self.flags & !FLAG_SCORES
        };
    }

    /// The options as sent (not validated).
    pub fn options(&self) -> Options {
        Options {
            speed_beta: self.speed_beta,
            coast: self.coast,
            scores: self.flags & FLAG_SCORES != 0,
            // not on the wire: only through a preset method (improved)
            ..Options::default()
        }
    }

    /// Set which map of the time of day the request asks for.
    pub fn set_map_time(&mut self, when: MapTime) {
        (self.time_mode, self.time) = when.to_wire();
    }

    /// The map name as bytes (without the NUL padding).
    pub fn map_name(&self) -> &[u8] {
        let end = self
            .map
            .iter()
            .position(|&b| b == 0)
            .unwrap_or(MAP_NAME_BYTES);
        &self.map[..end]
    }

    /// Set the map name; `Err` when it is empty, longer than `MAP_NAME_BYTES - 1` bytes or
    /// holds a NUL byte.
    pub fn set_map_name(&mut self, name: &str) -> Result<(), String> {
        encode_map_name(name).map(|m| self.map = m)
    }
}

/// A map name in its wire form; `Err` names what is wrong with it.
pub fn encode_map_name(name: &str) -> Result<[u8; MAP_NAME_BYTES], String> {
    let b = name.as_bytes();
    if b.is_empty() {
        return Err("map name is empty".into());
    }
    if b.len() >= MAP_NAME_BYTES {
        return Err(format!(
            "map name '{name}' is {} bytes, at most {} are allowed",
            b.len(),
            MAP_NAME_BYTES - 1
        ));
    }
    if b.contains(&0) {
        return Err(format!(
            "map name '{}' holds a NUL byte",
            name.escape_debug()
        ));
    }
    let mut out = [0u8; MAP_NAME_BYTES];
    out[..b.len()].copy_from_slice(b);
    Ok(out)
}

/// One row of an agent's observed history.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("cliff.protocol.v2.Observation")]
#[repr(C)]
pub struct Observation {
    /// Agent index in the request (`0..agents`, rows grouped by agent).
    pub agent: u32,
    /// [`FLAG_VELOCITY`] when `speed` and `heading` are set.
    pub flags: u32,
    /// Time (s), strictly increasing within an agent.
    pub t: f64,
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// Speed (m/s), when [`FLAG_VELOCITY`] is set.
    pub speed: f64,
    /// Heading (rad), when [`FLAG_VELOCITY`] is set.
    pub heading: f64,
}

impl Observation {
    /// A timestamped position.
    pub fn position(t: f64, x: f64, y: f64) -> Self {
        Observation {
            agent: 0,
            flags: 0,
            t,
            x,
            y,
            speed: 0.0,
            heading: 0.0,
        }
    }

    /// A timestamped position with the tracker's speed and heading.
    pub fn with_velocity(t: f64, x: f64, y: f64, speed: f64, heading: f64) -> Self {
        Observation {
            agent: 0,
            flags: FLAG_VELOCITY,
            t,
            x,
            y,
            speed,
            heading,
        }
    }
}

/// Requests the protocol's unit tests share: a header for the demo map and a walker's
/// history.
#[cfg(test)]
pub(crate) mod fixtures {
    use cliff::predict::Params;

    use super::{Observation, RequestHeader};

    /// A header with the default parameters for `agents` agents on the map `demo`.
    pub(crate) fn header(agents: u32) -> RequestHeader {
        let mut h = RequestHeader::from_params(&Params::default());
        h.agents = agents;
        h.set_map_name("demo").unwrap();
        h
    }

    /// `n` rows of agent `agent` walking east at 1.25 m/s, every 0.4 s.
    pub(crate) fn walk(agent: u32, n: usize) -> Vec<Observation> {
        (0..n)
            .map(|i| Observation {
                agent,
                ..Observation::position(i as f64 * 0.4, -10.0 + i as f64 * 0.5, 0.5)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_names_are_checked() {
        assert!(encode_map_name("demo").is_ok());
        assert!(encode_map_name("").is_err());
        assert!(encode_map_name(&"x".repeat(64)).is_err());
        assert!(encode_map_name(&"x".repeat(63)).is_ok());
        assert!(encode_map_name("a\0b").is_err());
        let mut h = RequestHeader::default();
        h.set_map_name("thor1").unwrap();
        assert_eq!(h.map_name(), b"thor1");
    }
}
