//! hevo's wire protocol: the `hevo.v1` gRPC services generated from `hevo/v1/hevo.proto`
//! (compiled with protox at build time, no system `protoc`), the one place where sim-core's
//! types are converted to and from protobuf messages ([`convert`]), the shared-token
//! authentication both sides use ([`auth`]), and client connections with optional TLS
//! ([`client`]). The master, the worker and the client commands all build on this crate, so
//! they cannot disagree about the format.

pub mod auth;
pub mod client;
pub mod codec;
pub mod convert;

/// The generated `hevo.v1` messages, clients and servers.
#[allow(
    clippy::all,
    clippy::pedantic,
    missing_debug_implementations,
    rust_2018_idioms
)]
pub mod v1 {
    tonic::include_proto!("hevo.v1");
}

/// Whether a wire job state is final (succeeded, failed or cancelled): the master sends no
/// more events for such a job, and a client following it stops there.
pub fn is_final(state: i32) -> bool {
    matches!(
        v1::JobState::try_from(state),
        Ok(v1::JobState::Succeeded | v1::JobState::Failed | v1::JobState::Cancelled)
    )
}

/// The encoded file descriptor set of `hevo.v1`, for the server reflection service.
pub const FILE_DESCRIPTOR_SET: &[u8] =
    include_bytes!(concat!(env!("OUT_DIR"), "/hevo_v1_descriptor.bin"));

/// The largest message either side decodes: far above any batch or result set hevo produces
/// (a generation of 100 genomes x 50 samples is about 100 KiB, a job's result files a few
/// MiB), low enough that a hostile peer cannot make the other side allocate without bound.
pub const MAX_MESSAGE_BYTES: usize = 64 * 1024 * 1024;

/// The service names, as used by the health service.
pub const JOB_SERVICE: &str = "hevo.v1.JobService";
/// See [`JOB_SERVICE`].
pub const WORKER_SERVICE: &str = "hevo.v1.WorkerService";
