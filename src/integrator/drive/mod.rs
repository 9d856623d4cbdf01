//! The loops that drive the kernels: the camera-sample loop over tiles
//! ([`pixels`]) and the progressive loop over iterations with a halting rule
//! ([`progressive`]).

pub(crate) mod pixels;
pub mod progressive;

pub use progressive::*;
