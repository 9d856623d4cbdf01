//! Network front ends over the transport-neutral [`crate::job::Service`]: REST (axum)
//! and gRPC (tonic). Handlers only parse, call and map errors.

pub mod error;
pub mod grpc;
pub mod http;
pub mod listen;
