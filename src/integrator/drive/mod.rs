//! The loops that drive the kernels: the camera-sample loop over tiles
//! ([`pixels`]), the light-path loop over fixed chunks ([`light`]), and the
//! progressive loop over iterations with a halting rule ([`progressive`]).

pub(crate) mod light;
pub(crate) mod pixels;
pub mod progressive;

pub use progressive::*;
