//! Accelerators for the stored points and beams of photon and merging estimators: a
//! hash grid for fixed-radius point queries and a Morton-ordered BVH for segment
//! queries (over points or beams). Both
//! are built in parallel and report points in an order that does not depend on the
//! number of threads, so an iteration's image is the same on any machine.

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
