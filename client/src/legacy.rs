//! Protocol version 1's iceoryx2 types, kept only so that a daemon can answer clients of
//! version 1 with [`Status::BadVersion`] instead of leaving them without a daemon.
//!
//! iceoryx2 matches services by name and by the type names of their payloads and
//! headers, so a version 1 client cannot open a service of version 2's types. Version 1
//! served its requests under the bare service name (`cliff/predict`); version 2 moved to
//! [`ipc_service_name`](crate::protocol::ipc_service_name) (`cliff/predict/v2`), and a
//! daemon of version 2 still creates the bare name with the types below. Whatever
//! arrives there is answered with an empty response: status [`Status::BadVersion`],
//! field [`Field::Version`], `limit` and `version` the daemon's [`PROTOCOL_VERSION`]. A
//! version 1 client reports that as "daemon speaks protocol 2, this client 1".
//!
//! The layouts are version 1's, field for field; nothing here is used for predictions.
//!
//! ```
//! use cliff_client::legacy;
//! let h = legacy::bad_version_response(7);
//! assert_eq!((h.version, h.status, h.request_id, h.limit), (2, 1, 7, 2));
//! ```

use iceoryx2::prelude::ZeroCopySend;

use crate::protocol::{Field, MAP_NAME_BYTES, PROTOCOL_VERSION, Status};

/// The protocol version of these types.
pub const VERSION: u32 = 1;

/// The iceoryx2 service name version 1 used for the daemon's service name `service`:
/// the name itself.
pub fn ipc_service_name(service: &str) -> String {
    service.to_string()
}

/// Version 1's request header (the iceoryx2 request user header).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("cliff.protocol.v1.RequestHeader")]
#[repr(C)]
#[allow(missing_docs)]
pub struct RequestHeader {
    pub version: u32,
    pub kind: u32,
    pub request_id: u64,
    pub listener_id: [u64; 2],
    pub map: [u8; MAP_NAME_BYTES],
    pub method: u32,
    pub heading_rule: u32,
    pub k: u32,
    pub agents: u32,
    pub dt: f64,
    pub horizon: f64,
    pub beta: f64,
    pub radius: f64,
    pub seed: u64,
}

impl Default for RequestHeader {
    /// A version 1 predict request for no agents (what a version 1 client sends, up to
    /// its map name and parameters).
    fn default() -> Self {
        RequestHeader {
            version: VERSION,
            kind: 0,
            request_id: 0,
            listener_id: [0, 0],
            map: [0; MAP_NAME_BYTES],
            method: 0,
            heading_rule: 0,
            k: 20,
            agents: 0,
            dt: 0.4,
            horizon: 12.0,
            beta: 1.0,
            radius: std::f64::consts::FRAC_1_SQRT_2,
            seed: 0,
        }
    }
}

/// Version 1's history row (the request payload element).
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("cliff.protocol.v1.Observation")]
#[repr(C)]
#[allow(missing_docs)]
pub struct Observation {
    pub agent: u32,
    pub flags: u32,
    pub t: f64,
    pub x: f64,
    pub y: f64,
    pub speed: f64,
    pub heading: f64,
}

/// Version 1's response header (the iceoryx2 response user header).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ZeroCopySend)]
#[type_name("cliff.protocol.v1.ResponseHeader")]
#[repr(C)]
#[allow(missing_docs)]
pub struct ResponseHeader {
    pub version: u32,
    pub status: u32,
    pub request_id: u64,
    pub agents: u32,
    pub k: u32,
    pub steps: u32,
    pub agent: u32,
    pub row: u32,
    pub field: u32,
    pub limit: u32,
    pub awake_us: u32,
}

/// The answer to every request of version 1: [`Status::BadVersion`] for the version
/// field, the daemon's [`PROTOCOL_VERSION`] as `version` and as `limit`, no batch.
pub fn bad_version_response(request_id: u64) -> ResponseHeader {
    ResponseHeader {
        version: PROTOCOL_VERSION,
        status: Status::BadVersion.code(),
        request_id,
        agents: 0,
        k: 0,
        steps: 0,
        agent: u32::MAX,
        row: u32::MAX,
        field: Field::Version as u32,
        limit: PROTOCOL_VERSION,
        awake_us: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn version_1_layouts_are_kept() {
        // sizes as version 1 had them (its wire encoding's header and row sizes)
        assert_eq!(std::mem::size_of::<RequestHeader>(), 152);
        assert_eq!(std::mem::size_of::<Observation>(), 48);
        assert_eq!(std::mem::size_of::<ResponseHeader>(), 48);
        // the version 2 response header starts with version 1's fields
        let h = bad_version_response(9);
        let v2 = crate::protocol::ResponseHeader {
            version: h.version,
            status: h.status,
            request_id: h.request_id,
            agent: h.agent,
            row: h.row,
            field: h.field,
            limit: h.limit,
            ..Default::default()
        };
        let r = crate::protocol::Rejection::from_header(&v2).unwrap();
        assert_eq!(
            (r.status, r.field, r.limit),
            (Status::BadVersion, Field::Version, 2)
        );
    }
}
