//! The daemon's iceoryx2 port and request types (protocol version 2, and version 1's
//! for the old-client answerer).

use cliff_client::legacy;
use cliff_client::protocol::{Observation, RequestHeader, ResponseHeader};
use iceoryx2::active_request::ActiveRequest;
use iceoryx2::port::server::Server;
use iceoryx2::prelude::*;

/// The server port of protocol version 2.
pub(super) type Port = Server<ipc::Service, [Observation], RequestHeader, [u32], ResponseHeader>;
/// The server port of protocol version 1's service.
pub(super) type LegacyPort = Server<
    ipc::Service,
    [legacy::Observation],
    legacy::RequestHeader,
    [u32],
    legacy::ResponseHeader,
>;
/// Protocol version 1's request-response service.
pub(super) type LegacyService = iceoryx2::service::port_factory::request_response::PortFactory<
    ipc::Service,
    [legacy::Observation],
    legacy::RequestHeader,
    [u32],
    legacy::ResponseHeader,
>;
/// A received request of protocol version 2, until its response is sent.
pub(super) type Active =
    ActiveRequest<ipc::Service, [Observation], RequestHeader, [u32], ResponseHeader>;
/// A loaned response of protocol version 2.
pub(super) type Response = iceoryx2::response_mut::ResponseMut<ipc::Service, [u32], ResponseHeader>;
