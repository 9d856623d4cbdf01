//! Accelerators for the stored points of photon and merging estimators: a hash grid
//! for fixed-radius point queries and a Morton-ordered BVH for segment queries. Both
//! are built in parallel and report points in an order that does not depend on the
//! number of threads, so an iteration's image is the same on any machine.

pub mod hashgrid;
pub(crate) mod huge;
pub mod light_tree;
pub mod point_bvh;

pub use hashgrid::HashGrid;
pub use point_bvh::{Point, PointBvh};
