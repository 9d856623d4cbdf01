//! The progressive radius of every density estimator (points, point x beam, beam x
//! beam, surface photons): one schedule, parameterised by the kernel's dimension.

/// r_{j+1} for iteration j (from 0) of a kernel of dimension k: r_1 (prod_{i=1}^{j}
/// (i + alpha) / (i + 1))^(1/k) [Knaus and Zwicker 2011, eqs. (15), (20)]. Summed in
/// logarithms in f64, so the product neither underflows nor depends on anything but j;
/// j logarithms per iteration is about 1 ms at j = 10^5, nothing next to an iteration.
pub fn radius_schedule(r1: f32, alpha: f32, k: u32, iteration: u64) -> f32 {
    let a = alpha as f64;
    let log: f64 = (1..=iteration)
        .map(|i| ((i as f64 + a) / (i as f64 + 1.0)).ln())
        .sum();
    (r1 as f64 * (log / k as f64).exp()) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radius_follows_knaus_and_zwicker() {
        // r_{i+1}^k / r_i^k = (i + alpha) / (i + 1), i from 1.
        for k in [2u32, 3] {
            let alpha = 0.6f32;
            let mut prev = radius_schedule(0.5, alpha, k, 0) as f64;
            assert!((prev - 0.5).abs() < 1e-7);
            for j in 1..50u64 {
                let r = radius_schedule(0.5, alpha, k, j) as f64;
                let ratio = (r / prev).powi(k as i32);
                let expect = (j as f64 + alpha as f64) / (j as f64 + 1.0);
                assert!((ratio - expect).abs() < 1e-5, "k {k}, j {j}: {ratio}");
                prev = r;
            }
        }
        assert_eq!(radius_schedule(0.3, 1.0, 3, 1000), 0.3);
    }
}
