//! The command line of the `caustic` binary: its arguments and one module per group of
//! commands.

pub mod args;
pub mod bench;
pub mod client;
pub mod import;
pub mod render;
pub mod report;
pub mod serve;
