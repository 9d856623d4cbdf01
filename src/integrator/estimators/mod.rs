//! The density estimators that several algorithms share, and their accelerators:
//! the beam radiance estimate over photon points ([`beam_query`]: `vpm`, and the
//! media of `ppm` and `sppm`), photon beams and the beam x beam estimate ([`beams`],
//! [`beam_estimate`]: `ppb`, and `upbp`'s beams), a hash grid for fixed-radius point
//! queries, a Morton-ordered BVH for segment queries (over points or beams), and the
//! light tree of the many-light methods. The accelerators are built in parallel and
//! report points in an order that does not depend on the number of threads, so an
//! iteration's image is the same on any machine.
//!
//! Above [`crate::integrator::paths`], whose photons, segments and vertices they
//! gather; below the algorithms.

pub(crate) mod beam_estimate;
pub(crate) mod beam_query;
#[cfg(test)]
mod beam_tests;
pub(crate) mod beams;
pub mod hashgrid;
pub(crate) mod huge;
pub mod lbvh;
pub mod light_tree;

pub use hashgrid::HashGrid;
pub use lbvh::{Bounded, Lbvh, Point, PointBvh};
