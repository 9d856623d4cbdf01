//! Ray-light sampling: the pieces of virtual ray lights (Novák et al. 2012, "Virtual
//! ray lights for rendering scenes with participating media") with the five samplers
//! of the VRL thesis (Oppitz 2018, TU Wien). The integrator that draws ray lights from
//! the bidirectional light store builds on this module; nothing here traces rays.
//!
//! A ray light is a segment of a light subpath through a medium, y(u) = o_l + d_l u
//! for u in [0, U], carrying the subpath's throughput beta at its origin. Every point
//! of it scatters light, so it lights a camera segment x(t) = o_c + d_c t, t in
//! [0, T], through the double integral (volume to volume, Novák et al. eq. 3)
//!
//!   L = int_0^U int_0^T beta sigma_s(y) f_p(d_l, w) sigma_s(x) f_p(w, -d_c)
//!       T(o_l, y) T(y, x) T(o_c, x) V(y, x) / |x - y|^2 dt du,
//!
//! with w = (x - y) / |x - y|, and a surface point p with BSDF f_s through the single
//! integral (volume to surface, eq. 2)
//!
//!   L = int_0^U beta sigma_s(y) f_p(d_l, w) T(o_l, y) T(y, p) f_s(w) |cos theta_p|
//!       V(y, p) / |p - y|^2 du.
//!
//! The 1/|x - y|^2 is singular where the two rays pass close to each other; the
//! samplers differ in how much of it (and of the phase functions) their densities
//! cancel. Files: `pair` (the geometry of a light and a camera segment), `distance`
//! (1D densities on a segment), `marginal` (the asinh marginal of 1/w^2 on the light
//! ray), `advanced` (the phase-product fit on the camera ray), `samplers` (the five
//! joint densities), `contribution` (the estimators in a homogeneous medium), `beam`
//! (the offsets of virtual beam lights: a ray light blurred over a disk).

mod advanced;
mod beam;
mod contribution;
mod distance;
mod marginal;
mod pair;
mod samplers;
#[cfg(test)]
mod tests;

pub use advanced::{Phases, MAX_NODES};
pub use beam::{Beam, BeamOffset, BeamSample};
pub use contribution::{
    estimate_volume_to_surface, estimate_volume_to_volume, volume_to_surface, volume_to_volume,
    Grey, SurfacePoint, SurfaceSampler,
};
pub use distance::{Distance, EquiAngular, Exponential, Uniform};
pub use marginal::Marginal;
pub use pair::{Pair, Segment};
pub use samplers::{PairMedia, PairSample, Sampler};
