//! caustic: progressive, physically based global illumination, as a library, a CLI and
//! a render server.

pub mod api;
pub mod bench;
pub mod camera;
pub mod client;
pub mod film;
pub mod geometry;
pub mod integrator;
pub mod job;
pub mod json_numbers;
pub mod light;
pub mod material;
pub mod math;
pub mod medium;
pub mod scene;
pub mod server;
pub mod tev;
