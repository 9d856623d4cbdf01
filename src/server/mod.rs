//! Network front ends over the transport-neutral [`crate::job::Service`]: REST (axum)
//! and gRPC (tonic), the bearer-token check both share, and the web dashboard's static
//! files. Handlers only parse, call and map errors.

pub mod auth;
pub mod dashboard;
pub mod error;
pub mod grpc;
pub mod http;
pub mod listen;
