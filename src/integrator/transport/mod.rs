//! What every tracer shares: MIS between unidirectional strategies, next-event
//! estimation, and the random streams.

pub mod adjoint;
pub mod camera;
pub mod density_camera;
pub mod emit;
pub mod equiangular;
pub mod light_paths;
pub mod medium_walk;
pub mod mis;
pub mod nee;
pub mod params;
pub mod radius;
pub mod streams;

pub use mis::{emitted, escaped, Heuristic};
pub use streams::{Stream, PATHS_PER_TASK};
