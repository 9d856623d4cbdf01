//! The photon family: progressive and stochastic progressive photon mapping
//! ([`sppm`], which holds `ppm` too), volumetric photon mapping ([`vpm`]) and
//! progressive photon beams ([`ppb`]). Each is a thin variant over the light walk and
//! the density estimators below it; none imports another.

pub mod ppb;
pub mod sppm;
pub mod vpm;
