use crate::math::{Rgb, Vec2, Vec3, Vec3A};

use super::{BsdfSample, Material, Mode};

/// A linear combination of materials: Mitsuba 0.x's `mixturebsdf` (any number of
/// components, weights summing to at most 1) and Mitsuba 3's `blendbsdf` (two
/// components, weights 1 - w and w). f = sum_k w_k f_k.
///
/// A component is picked with probability p_k = w_k / sum(w), so the continuous
/// density is pdf = sum_k p_k pdf_k (the one-sample MIS "balance" density of the
/// components, as Mitsuba's `blendbsdf` returns): a sample from one component is
/// weighted f / pdf over all of them, which keeps `pdf` equal to the density `sample`
/// draws from and MIS right. A delta lobe of a component stays a delta lobe of the
/// mixture, picked with probability p_k times the component's own, and weighted
/// w_k / p_k times the component's weight; continuous lobes never see it.
#[derive(Clone, Debug, PartialEq)]
pub struct Mixture {
    pub components: Vec<Material>,
    /// w_k, non-negative, one per component.
    pub weights: Vec<f32>,
}

impl Mixture {
    /// p_k = w_k / sum(w), the probability that `sample` picks component k.
    #[inline]
    fn prob(&self, k: usize) -> f32 {
        let total: f32 = self.weights.iter().sum();
        if total > 0.0 {
            self.weights[k].max(0.0) / total
        } else {
            0.0
        }
    }

    #[inline(never)]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: Mode) -> Rgb {
        let mut f = Rgb::ZERO;
        for (m, w) in self.components.iter().zip(&self.weights) {
            if *w > 0.0 {
                f += m.eval(wo, wi, mode) * *w;
            }
        }
        f
    }

    #[inline(never)]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        (0..self.components.len())
            .map(|k| match self.prob(k) {
                p if p > 0.0 => p * self.components[k].pdf(wo, wi),
                _ => 0.0,
            })
            .sum()
    }

    /// Picks component k with probability q(k) / sum(q), and rescales `u` to [0, 1)
    /// within k's share for reuse inside the component.
    fn pick(&self, u: f32, q: impl Fn(usize) -> f32) -> Option<(usize, f32)> {
        let n = self.components.len();
        let total: f32 = (0..n).map(&q).sum();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        let target = u * total;
        let (mut acc, mut chosen) = (0.0, None);
        for k in 0..n {
            let qk = q(k);
            if qk <= 0.0 {
                continue;
            }
            chosen = Some((k, acc, qk));
            if target < acc + qk {
                break;
            }
            acc += qk;
        }
        let (k, lo, qk) = chosen?;
        Some((k, ((target - lo) / qk).clamp(0.0, 1.0 - f32::EPSILON)))
    }

    #[inline(never)]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: Mode) -> Option<BsdfSample> {
        let (k, u_lobe) = self.pick(u_lobe, |k| self.prob(k))?;
        let (w, p) = (self.weights[k], self.prob(k));
        let s = self.components[k].sample(wo, u_lobe, u, mode)?;
        if s.delta {
            return Some(BsdfSample {
                weight: s.weight * (w / p),
                pdf: s.pdf * p,
                ..s
            });
        }
        let wi: Vec3 = s.wi.into();
        let pdf = self.pdf(wo, wi);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let f = self.eval(wo, wi, mode);
        Some(BsdfSample {
            wi: s.wi,
            weight: Vec3A::from(f / pdf),
            pdf,
            delta: false,
        })
    }

    /// Probability that `sample` picks a delta lobe from `wo`.
    #[inline(never)]
    pub fn delta_probability(&self, wo: Vec3) -> f32 {
        (0..self.components.len())
            .map(|k| self.delta_weight(k, wo))
            .sum()
    }

    /// `sample` restricted to the delta lobes: one of them picked by `u_lobe` in
    /// proportion to its probability under `sample`, and weighted as `sample` weighs
    /// it (f over its overall probability).
    #[inline(never)]
    pub fn sample_delta(&self, wo: Vec3, u_lobe: f32, u: Vec2, mode: Mode) -> Option<BsdfSample> {
        let (k, u_lobe) = self.pick(u_lobe, |k| self.delta_weight(k, wo))?;
        let s = self.components[k].sample_delta(wo, u_lobe, u, mode)?;
        let p = self.prob(k);
        Some(BsdfSample {
            weight: s.weight * (self.weights[k] / p),
            pdf: s.pdf * p,
            ..s
        })
    }

    /// p_k times the probability that component k samples a delta lobe.
    fn delta_weight(&self, k: usize, wo: Vec3) -> f32 {
        match self.prob(k) {
            p if p > 0.0 => p * self.components[k].delta_share(wo),
            _ => 0.0,
        }
    }

    #[inline(never)]
    pub fn is_delta(&self) -> bool {
        self.components.iter().all(Material::is_delta)
    }

    #[inline(never)]
    pub fn is_black_from(&self, wo: Vec3) -> bool {
        self.components.iter().all(|m| m.is_black_from(wo))
    }

    #[inline(never)]
    pub fn albedo(&self) -> Rgb {
        let mut a = Rgb::ZERO;
        for (m, w) in self.components.iter().zip(&self.weights) {
            a += m.albedo() * *w;
        }
        a
    }
}
