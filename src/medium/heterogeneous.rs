//! Heterogeneous media (voxel grids, procedural noise): sigma_t(x) = density(x) *
//! sigma_t, sampled by null-collision tracking against a coarse majorant grid.
//!
//! Free flights use spectral tracking (Kutz et al. 2017, "Spectral and decomposition
//! tracking", sec. 5): one grey majorant sigma_bar >= max_c sigma_t,c per cell; at each
//! tentative collision the event is scattering or null with probabilities proportional
//! to the throughput-weighted sigma_s and sigma_n = sigma_bar - sigma_t, and the path
//! weight is multiplied by sigma_event / (sigma_bar P_event) per channel. Absorption
//! enters as that weight, so nothing is killed and chromatic media need no special
//! case. Transmittance for shadow rays is ratio tracking (Novak et al. 2014) over the
//! same majorants, with Russian roulette once the estimate is small.

use super::voxels::{DensityField, MajorantGrid, MajorantWalk, VoxelGrid};
use super::{Flight, Phase};
use crate::math::{max_component, Rgb, Rng, Vec3};
use glam::Affine3A;

#[derive(Clone, Debug)]
pub struct Heterogeneous {
    pub density: DensityField,
    /// Multiplies `albedo` when present (grey, in [0, 1]).
    pub albedo_grid: Option<VoxelGrid>,
    pub albedo: Rgb,
    /// Extinction per unit density (the scene's sigma_t times its scale).
    pub sigma_t: Rgb,
    pub phase: Phase,
    /// World space to the unit cube the fields live in.
    pub to_local: Affine3A,
    pub majorants: MajorantGrid,
}

/// A ray clipped to the unit cube, in local coordinates but world distances.
struct Local {
    o: Vec3,
    d: Vec3,
    t0: f32,
    t1: f32,
}

impl Heterogeneous {
    pub fn new(
        density: DensityField,
        albedo: Rgb,
        albedo_grid: Option<VoxelGrid>,
        sigma_t: Rgb,
        phase: Phase,
        to_local: Affine3A,
    ) -> Self {
        let majorants = MajorantGrid::build(&density);
        Heterogeneous {
            density,
            albedo_grid,
            albedo,
            sigma_t,
            phase,
            to_local,
            majorants,
        }
    }

    /// The part of the world ray o + t d (unit d), t in [0, tmax], inside the cube.
    #[inline]
    fn clip(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<Local> {
        let lo = self.to_local.transform_point3(o);
        let ld = self.to_local.transform_vector3(d);
        let inv = ld.recip();
        let a = -lo * inv;
        let b = (Vec3::ONE - lo) * inv;
        // NaN from 0 * inf (a ray in a face's plane) must not widen the interval.
        let near = a.min(b);
        let far = a.max(b);
        let t0 = near.max_element().max(0.0);
        let t1 = far.min_element().min(tmax);
        (t0 < t1).then_some(Local {
            o: lo,
            d: ld,
            t0,
            t1,
        })
    }

    /// The far end of o + t d (unit d), t in [0, tmax], inside the field's box (0 when
    /// the ray misses it).
    pub fn support_end(&self, o: Vec3, d: Vec3, tmax: f32) -> f32 {
        self.clip(o, d, tmax).map_or(0.0, |l| l.t1)
    }

    /// Extinction and scattering coefficients at a local point.
    #[inline]
    fn coefficients(&self, p: Vec3, cap: f32) -> (Rgb, Rgb) {
        let density = self.density.eval(p).min(cap);
        let sigma_t = self.sigma_t * density;
        let albedo = match &self.albedo_grid {
            Some(g) => self.albedo * g.eval(p).clamp(0.0, 1.0),
            None => self.albedo,
        };
        (sigma_t, sigma_t * albedo)
    }

    /// Scattering coefficient at world point `p` (zero outside the field's cube): the
    /// sigma_s that `sample_flight` puts into the weight of a scattering event there.
    pub fn sigma_s_at(&self, p: Vec3) -> Rgb {
        let l = self.to_local.transform_point3(p);
        if l.min_element() < 0.0 || l.max_element() > 1.0 {
            return Rgb::ZERO;
        }
        self.coefficients(l, f32::INFINITY).1
    }

    /// The grey (channel-mean) sigma_t at world point `p`, 0 outside the field's cube.
    pub fn mis_sigma_at(&self, p: Vec3) -> f32 {
        let l = self.to_local.transform_point3(p);
        if l.min_element() < 0.0 || l.max_element() > 1.0 {
            return 0.0;
        }
        self.density.eval(l) * self.sigma_t.element_sum() / 3.0
    }

    /// The midpoint rule with `MIS_STEPS` equal steps for the grey optical depth of
    /// o + t d (unit d), t in [t0, t1], over the part inside the field's cube: points
    /// symmetric about the middle, so the same from either end. An MIS proxy only
    /// (which ranks techniques): estimates of the image's transmittance are unbiased
    /// ratio tracking.
    pub fn mis_depth(&self, o: Vec3, d: Vec3, t0: f32, t1: f32) -> f32 {
        const MIS_STEPS: usize = 4;
        // Also NaN bounds: no piece.
        if t1.partial_cmp(&t0) != Some(std::cmp::Ordering::Greater) {
            return 0.0;
        }
        let Some(r) = self.clip(o + d * t0, d, t1 - t0) else {
            return 0.0;
        };
        let h = (r.t1 - r.t0) / MIS_STEPS as f32;
        let sum: f32 = (0..MIS_STEPS)
            .map(|i| self.density.eval(r.o + r.d * (r.t0 + (i as f32 + 0.5) * h)))
            .sum();
        sum * h * self.sigma_t.element_sum() / 3.0
    }

    /// Single-scattering albedo at world point `p`.
    #[inline]
    pub fn albedo_at(&self, p: Vec3) -> Rgb {
        match &self.albedo_grid {
            Some(g) => self.albedo * g.eval(self.to_local.transform_point3(p)).clamp(0.0, 1.0),
            None => self.albedo,
        }
    }

    /// The null-collision process shared by every estimator here: tentative
    /// collisions at exponential steps of rate sigma_bar = cell majorant * max sigma_t,
    /// cell by cell along the ray clipped to the volume. `event(rng, p, t, sigma_bar,
    /// majorant)` sees each one (p in local coordinates) and ends the walk by returning
    /// `Some`; `None` means the walk left the segment.
    #[inline]
    fn track<R>(
        &self,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        rng: &mut Rng,
        mut event: impl FnMut(&mut Rng, Vec3, f32, f32, f32) -> Option<R>,
    ) -> Option<R> {
        let r = self.clip(o, d, tmax)?;
        let scale = max_component(self.sigma_t);
        for (ta, tb, maj) in MajorantWalk::new(&self.majorants, r.o, r.d, r.t0, r.t1) {
            let sigma_bar = maj * scale;
            if sigma_bar <= 0.0 {
                continue;
            }
            let mut t = ta;
            loop {
                t -= (1.0 - rng.next_f32()).ln() / sigma_bar;
                if t >= tb {
                    break;
                }
                if let Some(out) = event(rng, r.o + r.d * t, t, sigma_bar, maj) {
                    return Some(out);
                }
            }
        }
        None
    }

    /// Spectral tracking; see the module notes.
    pub fn sample_flight(&self, o: Vec3, d: Vec3, tmax: f32, beta: Rgb, rng: &mut Rng) -> Flight {
        let mut w = Rgb::ONE;
        let end = self.track(o, d, tmax, rng, |rng, p, t, sigma_bar, maj| {
            let (st, ss) = self.coefficients(p, maj);
            let sn = (Rgb::splat(sigma_bar) - st).max(Rgb::ZERO);
            let bw = (beta * w).abs();
            let ps = (bw * ss).element_sum();
            let pn = (bw * sn).element_sum();
            let total = ps + pn;
            if total.is_nan() || total <= 0.0 {
                return Some(Flight::Absorbed);
            }
            if rng.next_f32() * total < ps {
                w *= ss * (total / (sigma_bar * ps));
                return Some(Flight::Scatter { t, weight: w });
            }
            w *= sn * (total / (sigma_bar * pn));
            None
        });
        end.unwrap_or(Flight::Pass { weight: w })
    }

    /// Ratio-tracking estimate of the transmittance over t in [0, tmax].
    pub fn transmittance(&self, o: Vec3, d: Vec3, tmax: f32, rng: &mut Rng) -> Rgb {
        let mut tr = Rgb::ONE;
        let killed = self.track(o, d, tmax, rng, |rng, p, _, sigma_bar, maj| {
            let density = self.density.eval(p).min(maj);
            tr *= (Rgb::ONE - self.sigma_t * (density / sigma_bar)).max(Rgb::ZERO);
            // Roulette keeps long, dense segments from costing many lookups for a
            // contribution that is nearly zero.
            let m = max_component(tr);
            if m < 0.1 {
                let q = (1.0 - m).min(0.9);
                if rng.next_f32() < q {
                    return Some(());
                }
                tr /= 1.0 - q;
            }
            None
        });
        if killed.is_some() {
            Rgb::ZERO
        } else {
            tr
        }
    }

    /// Delta-tracking estimate (0 or 1 per channel group) of the transmittance: the
    /// probability that a grey free flight passes. Used by tests against ratio tracking
    /// and the closed form.
    pub fn delta_tracking_passes(&self, o: Vec3, d: Vec3, tmax: f32, rng: &mut Rng) -> bool {
        let sigma_max = max_component(self.sigma_t);
        let collided = self.track(o, d, tmax, rng, |rng, p, _, sigma_bar, maj| {
            let density = self.density.eval(p).min(maj);
            (rng.next_f32() * sigma_bar < sigma_max * density).then_some(())
        });
        collided.is_none()
    }

    /// The mean over the cube of the cell majorants' extinction: a rate for drawing
    /// distances roughly in proportion to transmittance. The global majorant would make
    /// T(t) / exp(-rate t) grow as exp((rate - sigma_t) t) in thin regions, a weight
    /// without a useful bound.
    pub fn mean_sigma_t(&self) -> f32 {
        self.majorants.mean() * max_component(self.sigma_t)
    }

    /// Largest extinction anywhere (for statistics and scene checks).
    pub fn max_sigma_t(&self) -> f32 {
        self.majorants.global_max() * max_component(self.sigma_t)
    }
}
