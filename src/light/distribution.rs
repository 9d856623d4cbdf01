//! Piecewise-constant 1D and 2D distributions for discrete and continuous sampling.

use glam::Vec2;

#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    func: Vec<f32>,
    /// cdf[0] = 0, cdf[n] = 1.
    cdf: Vec<f32>,
    /// Mean of the weights as given (0 when they are all zero).
    integral: f32,
    /// The mean of `func`, which sampling normalises by (1 for the uniform fallback).
    norm: f32,
}

impl Distribution1D {
    /// From non-negative weights over n equal bins of [0, 1). All-zero weights give the
    /// uniform distribution, so sampling never fails.
    pub fn new(weights: &[f32]) -> Self {
        let n = weights.len().max(1);
        let mut func: Vec<f32> = weights.iter().map(|w| w.max(0.0)).collect();
        if func.is_empty() {
            func.push(1.0);
        }
        let mut cdf = Vec::with_capacity(n + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0);
        for &f in &func {
            acc += f as f64 / n as f64;
            cdf.push(acc as f32);
        }
        let integral = acc as f32;
        if integral > 0.0 {
            for c in cdf.iter_mut() {
                *c = (*c as f64 / acc) as f32;
            }
        } else {
            func.iter_mut().for_each(|f| *f = 1.0);
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f32 / n as f32;
            }
        }
        cdf[n] = 1.0;
        Distribution1D {
            func,
            cdf,
            integral,
            norm: if integral > 0.0 { integral } else { 1.0 },
        }
    }

    pub fn len(&self) -> usize {
        self.func.len()
    }

    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Mean of the weights (the integral over [0, 1)); 0 when all weights are zero,
    /// even though sampling then falls back to uniform.
    pub fn integral(&self) -> f32 {
        self.integral
    }

    #[inline]
    fn find(&self, u: f32) -> usize {
        // One bin (a scene's only light, a light of one primitive) needs no search.
        if self.func.len() == 1 {
            return 0;
        }
        // Largest i with cdf[i] <= u, restricted to bins of non-zero probability.
        let i = self.cdf.partition_point(|&c| c <= u).saturating_sub(1);
        i.min(self.func.len() - 1)
    }

    /// Picks a bin with probability weight / sum; returns (index, probability, u
    /// remapped to [0, 1) within the bin for reuse).
    #[inline]
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        if self.cdf.len() == 2 {
            // One bin (one light, a light of one primitive), whose cdf is [0, 1]: the
            // search and the remap's division are identities, and on the path of
            // every light sample.
            return (0, 1.0, u.clamp(0.0, 1.0 - f32::EPSILON));
        }
        let i = self.find(u);
        let p = self.pmf(i);
        let width = self.cdf[i + 1] - self.cdf[i];
        let ur = if width > 0.0 {
            ((u - self.cdf[i]) / width).clamp(0.0, 1.0 - f32::EPSILON)
        } else {
            0.0
        };
        (i, p, ur)
    }

    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// A point in [0, 1) and its density.
    #[inline]
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        let i = self.find(u);
        let width = self.cdf[i + 1] - self.cdf[i];
        let du = if width > 0.0 {
            (u - self.cdf[i]) / width
        } else {
            0.0
        };
        let n = self.func.len() as f32;
        let x = ((i as f32 + du) / n).min(1.0 - f32::EPSILON);
        (x, self.func[i] / self.norm, i)
    }

    #[inline]
    pub fn pdf_continuous(&self, x: f32) -> f32 {
        let n = self.func.len();
        let i = ((x * n as f32) as usize).min(n - 1);
        self.func[i] / self.norm
    }
}

/// p(u, v) = p(v) p(u | v) over a grid of rows (v) and columns (u).
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    rows: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    pub fn new(weights: &[f32], width: usize, height: usize) -> Self {
        let rows: Vec<Distribution1D> = (0..height)
            .map(|y| Distribution1D::new(&weights[y * width..(y + 1) * width]))
            .collect();
        let marg: Vec<f32> = rows.iter().map(|r| r.integral()).collect();
        Distribution2D {
            rows,
            marginal: Distribution1D::new(&marg),
        }
    }

    /// A point in [0,1)^2 and its density with respect to area in [0,1)^2.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (v, pv, row) = self.marginal.sample_continuous(u.y);
        let (x, pu, _) = self.rows[row].sample_continuous(u.x);
        (Vec2::new(x, v), pv * pu)
    }

    #[inline]
    pub fn pdf(&self, p: Vec2) -> f32 {
        let h = self.rows.len();
        let row = ((p.y * h as f32) as usize).min(h - 1);
        self.marginal.pdf_continuous(p.y) * self.rows[row].pdf_continuous(p.x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One bin takes a shortcut; it must give what the general remap gives.
    #[test]
    fn one_bin_shortcut_matches_the_general_remap() {
        for w in [0.3f32, 5.0, 0.0] {
            let d = Distribution1D::new(&[w]);
            assert_eq!(d.cdf, vec![0.0, 1.0]);
            let top = 1.0 - f32::EPSILON / 2.0;
            for u in (0..=1000).map(|k| k as f32 / 1000.0 * top).chain([top]) {
                let width = d.cdf[1] - d.cdf[0];
                let general = ((u - d.cdf[0]) / width).clamp(0.0, 1.0 - f32::EPSILON);
                let (i, p, ur) = d.sample_discrete(u);
                assert_eq!(
                    (i, p.to_bits(), ur.to_bits()),
                    (0, width.to_bits(), general.to_bits())
                );
            }
        }
    }

    #[test]
    fn discrete_sampling_follows_weights_and_skips_zeros() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]);
        assert!((d.pmf(0) - 0.25).abs() < 1e-6);
        assert_eq!(d.pmf(1), 0.0);
        for k in 0..1000 {
            let (i, p, ur) = d.sample_discrete(k as f32 / 1000.0);
            assert_ne!(i, 1);
            assert!(p > 0.0 && (0.0..1.0).contains(&ur));
        }
    }

    #[test]
    fn continuous_density_integrates_to_one() {
        let d = Distribution2D::new(&[1.0, 2.0, 0.0, 5.0, 1.0, 1.0], 3, 2);
        let n = 300;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let p = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                sum += d.pdf(p) as f64 / (n * n) as f64;
            }
        }
        assert!((sum - 1.0).abs() < 1e-3, "{sum}");
        let (p, pdf) = d.sample(Vec2::new(0.3, 0.8));
        assert!((pdf - d.pdf(p)).abs() < 1e-4 * pdf);
    }
}
