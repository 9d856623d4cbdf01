//! Checks the recursive weights against the balance and power heuristics computed
//! from explicit path densities ([TR] sec. 2-3), on random non-specular paths with
//! an area light or a light at infinity and a pinhole camera, for every technique
//! set. Paths may have medium vertices (D = sigma_t from both sides instead of two
//! cosines) and segments with transmittance T < 1 in the densities of whatever is
//! sampled along them; the recursive side gets them as the module notes say.
use super::super::selection::{camera_rules_out, Rule};
use crate::integrator::paths::correlation::Fix;
use crate::integrator::paths::full_path::{FullPath as Path, Technique as Tech};
use crate::integrator::paths::partial::{
    transmittance, Merge, Merges, Mis, Partial, Site, MAX_MIS_DEPTH,
};
use crate::integrator::paths::parts::{Candidate, Parts, Scale, MEDIA};
use crate::integrator::transport::Heuristic;
use crate::math::Rng;

mod correlated;

fn random_path(rng: &mut Rng, n: usize, media: bool, infinite: bool) -> Path {
    let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    let mut p = Path {
        n,
        d2: (0..n).map(|_| r(0.05, 4.0)).collect(),
        tr: (0..n)
            .map(|_| if media { r(0.01, 1.0) } else { 1.0 })
            .collect(),
        cf: (0..=n).map(|_| r(0.05, 1.0)).collect(),
        cb: (0..=n).map(|_| r(0.05, 1.0)).collect(),
        pl: (0..=n).map(|_| r(0.05, 3.0)).collect(),
        pc: (0..=n).map(|_| r(0.05, 3.0)).collect(),
        site: vec![Site::Surface; n + 1],
        sin: (0..=n)
            .map(|_| if r(0.0, 1.0) < 0.1 { 0.0 } else { r(0.0, 1.0) })
            .collect(),
        pick: r(0.2, 1.0),
        infinite,
        a_direct: r(0.5, 4.0),
        e_pos: r(0.5, 4.0),
        e_dir: r(0.05, 1.0),
        camera: r(0.5, 3.0),
        long: false,
    };
    if media {
        for i in 1..n {
            if r(0.0, 1.0) < 0.5 {
                let sigma = r(0.05, 5.0);
                p.cf[i] = sigma;
                p.cb[i] = sigma;
                p.site[i] = Site::Medium;
            }
        }
    }
    p
}

const ALL_MERGES: [Merge; Merge::COUNT] = [
    Merge::Surface,
    Merge::Point3d,
    Merge::PointBeam2d,
    Merge::BeamBeam1d,
];

impl Path {
    /// M(x_i) as the recursion takes it: whichever subpath x_i is on, its camera-side
    /// segment is (x_i, x_{i+1}).
    fn vm(&self, m: &Mis, i: usize, camera_len: Option<u32>) -> f64 {
        m.merges(
            self.site[i],
            self.sigma(i),
            self.sin[i],
            camera_len,
            self.tr[i],
        )
    }

    /// d^2 / T of segment i as on_hit takes it (1 / T from infinity).
    fn seg(&self, i: usize) -> f32 {
        if i == 0 && self.infinite {
            1.0 / self.tr[0]
        } else {
            self.d2[i] / self.tr[i]
        }
    }

    fn emission(&self) -> f32 {
        self.pick * self.e_pos * self.e_dir
    }

    /// The light subpath's partial weights at vertex `k` (after the hit), the part
    /// of them that merges in media contribute, and every estimator's part.
    fn light_q(&self, m: &Mis, k: usize) -> (Partial, f64, Parts) {
        let direct = self.pick * self.a_direct;
        let mut q = m.light_start(direct, self.emission(), self.cf[0], false, !self.infinite);
        q = m.on_hit(q, self.seg(0), self.cb[1]);
        let mut parts = Parts::default();
        for i in 1..k {
            // As the light subpath does: the query beams' part of M(x_i) waits for
            // the T of the segment x_i leaves along; a medium vertex is on the camera
            // side of the merges in media before it.
            let (points, beams) = m.merge_parts(self.site[i], self.sigma(i), self.sin[i], None);
            let terms = m.unsettled_terms(self.site[i], self.sigma(i), self.sin[i], None);
            let (now, later) = m.defer_terms(terms, self.cf[i], self.pl[i]);
            let vm = if m.long_query { points } else { points + beams };
            if self.site[i] == Site::Medium && m.first_medium {
                q = m.cut(q, parts.media());
                parts = parts.without_media();
            }
            q = m.on_scatter(q, vm, self.cf[i], self.pl[i], self.pc[i], false);
            parts = m.scatter_parts(parts, now, self.cf[i], self.pl[i], self.pc[i], false);
            let (tr, cos) = (self.tr[i], self.cb[i + 1]);
            q = m.light_hit(q, later.sum(), self.seg(i), tr, cos);
            parts = m.hit_parts(parts, later, tr, cos);
        }
        (q, parts.media(), parts)
    }

    /// M(x_i) of a camera vertex, whose camera side has a medium vertex if `seen`.
    fn camera_vm(&self, m: &Mis, i: usize, len: u32, seen: bool) -> f64 {
        if self.site[i] == Site::Medium && m.cuts(seen) {
            0.0
        } else {
            self.vm(m, i, Some(len))
        }
    }

    /// Its terms, each estimator's ([`Mis::merge_terms`]).
    fn camera_terms(&self, m: &Mis, i: usize, len: u32, seen: bool) -> Parts {
        if self.site[i] == Site::Medium && m.cuts(seen) {
            Parts::default()
        } else {
            self.terms(m, i, Some(len))
        }
    }

    /// The terms of M(x_i) as [`Path::vm`] sums them.
    fn terms(&self, m: &Mis, i: usize, camera_len: Option<u32>) -> Parts {
        let (site, sigma, sin) = (self.site[i], self.sigma(i), self.sin[i]);
        m.merge_terms(site, sigma, sin, camera_len, self.tr[i])
    }

    /// The camera subpath's partial weights at vertex `k` (after the hit), with
    /// its length in segments, whether a vertex before x_k is in a medium, and every
    /// estimator's part of them.
    fn camera_q(&self, m: &Mis, k: usize) -> (Partial, u32, bool, Parts) {
        let n = self.n;
        let mut q = m.camera_start(self.camera);
        q = m.on_hit(q, self.seg(n - 1), self.cf[n - 1]);
        let (mut len, mut seen, mut parts) = (1, false, Parts::default());
        for i in (k + 1..n).rev() {
            let (vm, cos) = (self.camera_vm(m, i, len, seen), self.cb[i]);
            let terms = self.camera_terms(m, i, len, seen);
            seen |= self.site[i] == Site::Medium;
            q = m.on_scatter(q, vm, cos, self.pc[i], self.pl[i], false);
            parts = m.scatter_parts(parts, terms, cos, self.pc[i], self.pl[i], false);
            // An escaping ray: no cosine at infinity, only the 1 / T of its
            // segment (as the camera subpath applies on escape).
            let cos = if i == 1 && self.infinite {
                1.0
            } else {
                self.cf[i - 1]
            };
            q = m.on_hit(q, self.seg(i - 1), cos);
            parts = m.hit_parts(parts, Parts::default(), 1.0, cos);
            len += 1;
        }
        (q, len, seen, parts)
    }

    /// The weight the recursive quantities give technique `t`; with `scale`, the
    /// weight under every estimator's Mis(eta_k) scaled so, from the same unscaled
    /// subpaths and their [`Parts`].
    fn recursive_weight(&self, m: &Mis, t: Tech, scale: Option<&Scale>) -> f32 {
        self.fixed_weight(m, t, scale, (Fix::NONE, Fix::NONE))
    }

    /// The same with the light's and the camera's side fixed by correlation-aware
    /// MIS ([`Fix`]).
    fn fixed_weight(&self, m: &Mis, t: Tech, scale: Option<&Scale>, fix: (Fix, Fix)) -> f32 {
        let n = self.n;
        // A subpath's partial weights and a vertex's M(x) as `scale` has them.
        let q = |q: Partial, parts: Parts| scale.map_or(q, |s| m.rescale(q, &parts, s));
        let vm = |plain: f64, terms: Parts| scale.map_or(plain, |s| terms.dot(s));
        let (fl, fc) = fix;
        let ql = |x: Partial, parts: Parts| fl.apply(q(x, parts));
        let qc = |x: Partial, parts: Parts| fc.apply(q(x, parts));
        // The light side cut by `merge_depth: first` ([`Mis::cut`]).
        let cut = |(ql, vol, parts): (Partial, f64, Parts), cut: bool| {
            if cut {
                (m.cut(ql, vol), parts.without_media())
            } else {
                (ql, parts)
            }
        };
        match t {
            Tech::Connect(0) => {
                let (cq, _, _, parts) = self.camera_q(m, 0);
                m.weight_emitter_hit(qc(cq, parts), self.pick * self.a_direct, self.emission())
            }
            Tech::Connect(1) => {
                let (cq, len, seen, parts) = self.camera_q(m, 1);
                // Light sampling's solid-angle density, with the segment's T.
                let (direct_w, cos_light) = if self.infinite {
                    (self.a_direct, 1.0)
                } else {
                    (self.a_direct * self.d2[0] / self.cf[0], self.cf[0])
                };
                let vm1 = vm(
                    self.camera_vm(m, 1, len, seen),
                    self.camera_terms(m, 1, len, seen),
                );
                m.weight_light_sample(
                    qc(cq, parts),
                    vm1 * fc.rho,
                    self.pick,
                    direct_w / self.tr[0],
                    self.e_pos * self.e_dir,
                    cos_light,
                    self.cb[1],
                    self.pc[1],
                    self.pl[1],
                )
            }
            Tech::Connect(s) if s == n => {
                // x_{n-1} is on the camera side of the light's earlier vertices.
                let medium = self.site[n - 1] == Site::Medium;
                let (lq, parts) = cut(self.light_q(m, n - 1), m.cuts(medium));
                let camera_a = self.camera * self.cf[n - 1] / self.seg(n - 1);
                let vm1 = vm(self.vm(m, n - 1, Some(1)), self.terms(m, n - 1, Some(1)));
                m.weight_camera_connection((ql(lq, parts), vm1), camera_a, self.pc[n - 1])
            }
            Tech::Connect(s) => {
                let (cq, len, seen, cparts) = self.camera_q(m, s);
                let seg = self.seg(s - 1);
                // x_{s-1}, x_s and the camera vertices before it are the camera
                // side of the light's earlier vertices; x_s and those of x_{s-1}.
                let camera_medium = seen || self.site[s] == Site::Medium;
                let y_medium = self.site[s - 1] == Site::Medium;
                let (lq, lparts) = cut(self.light_q(m, s - 1), m.cuts(camera_medium || y_medium));
                let vm_y = if y_medium && m.cuts(camera_medium) {
                    0.0
                } else {
                    vm(self.vm(m, s - 1, None), self.terms(m, s - 1, None))
                };
                let vm_x = vm(
                    self.camera_vm(m, s, len, seen),
                    self.camera_terms(m, s, len, seen),
                );
                m.weight_connection(
                    (ql(lq, lparts), vm_y * fl.rho),
                    (qc(cq, cparts), vm_x * fc.rho),
                    self.pc[s] * self.cf[s - 1] / seg,
                    self.pl[s - 1] * self.cb[s] / seg,
                    self.pc[s - 1],
                    self.pl[s],
                )
            }
            Tech::Merge(j, k) => {
                let (cq, _, seen, cparts) = self.camera_q(m, j);
                // A merge in a medium is on the camera side of the light's vertices.
                let medium = self.site[j] == Site::Medium;
                assert!(!(medium && m.cuts(seen)), "{t:?} is no technique");
                let cuts = if medium { m.first_medium } else { m.cuts(seen) };
                let (lq, lparts) = cut(self.light_q(m, j), cuts);
                let own = m.eta(k, self.sigma(j), self.sin[j], self.tr[j]);
                let own = own * scale.map_or(1.0, |s| s.0[k as usize]);
                let all = vm(self.vm(m, j, None), self.terms(m, j, None));
                m.weight_merge(
                    ql(lq, lparts),
                    qc(cq, cparts),
                    (own * fc.rho, all * fc.rho),
                    self.pc[j],
                    self.pl[j],
                )
            }
        }
    }
}

/// Merge estimators of the tests: none, surfaces only ([TR]), or surfaces and
/// media with a different eta (as a volume kernel would have).
fn merges(vm: bool, volume: bool) -> Merges {
    let (radius, light_paths) = (0.01f32, 1000.0f32);
    let mut m = if vm {
        Merges::surface(radius, light_paths)
    } else {
        Merges::default()
    };
    if vm && volume {
        m = m.with(Merge::Point3d, 0.05, light_paths);
    }
    m
}

/// A set of [UPBP]'s estimators: `mask` bit k turns on `ALL_MERGES[k]`, each with
/// its own radius.
fn upbp(mask: u32) -> Merges {
    let radii = [0.01f32, 0.05, 0.02, 0.03];
    (0..Merge::COUNT)
        .filter(|k| mask & (1 << k) != 0)
        .fold(Merges::default(), |m, k| {
            m.with(ALL_MERGES[k], radii[k], 1000.0)
        })
}

/// How the weights of one `check` are set up beyond the estimators.
#[derive(Clone, Copy, Debug, Default)]
struct Setup {
    merge_first: bool,
    media: bool,
    long: bool,
    /// `merge_depth: first`.
    first: bool,
}

fn check(heuristic: Heuristic, vc: bool, merges: Merges, merge_first: bool, media: bool) {
    for (long, first) in [(false, false), (true, false), (false, true), (true, true)] {
        let setup = Setup {
            merge_first,
            media,
            long,
            first,
        };
        check_setup(heuristic, vc, merges, setup);
    }
}

/// Radius factors per estimator that the checks also weigh the paths with (0 turns
/// an estimator off): the unscaled subpaths' [`Parts`] must give the weights a job
/// with those radii would.
const RADIUS_FACTORS: [[f32; Merge::COUNT]; 4] = [
    [1.0; Merge::COUNT],
    [0.5, 2.0, 0.25, 3.0],
    [0.0, 1.5, 0.0, 0.5],
    [2.0, 0.0, 1.0, 0.0],
];

/// `merges` with each estimator's radius scaled by its factor in `s` (eta grows
/// with the kernel's support; 0 removes the estimator).
fn scaled_merges(merges: &Merges, s: [f32; Merge::COUNT]) -> Merges {
    let mut out = *merges;
    for (k, eta) in out.eta.iter_mut().enumerate() {
        let dim = [2, 3, 2, 1][k];
        *eta = eta
            .map(|e| e * (s[k] as f64).powi(dim))
            .filter(|&e| e > 0.0);
    }
    out
}

fn check_setup(heuristic: Heuristic, vc: bool, merges: Merges, setup: Setup) {
    let mut rng = Rng::new(3, 1, 4);
    let light_paths = 1000.0f32;
    let mis = |merges: Merges| {
        let mut m = Mis::new(heuristic, light_paths, vc, merges);
        m.merge_first = setup.merge_first;
        m.long_query = setup.long;
        m.first_medium = setup.first;
        m
    };
    let m = mis(merges);
    for n in 2..7 {
        for k in 0..40 {
            let infinite = k % 2 == 1;
            let mut path = random_path(&mut rng, n, setup.media, infinite);
            path.long = setup.long;
            for factors in RADIUS_FACTORS {
                let scaled = scaled_merges(&merges, factors);
                // As a job with those radii builds it, and the factors from ours.
                let separate = mis(scaled);
                let scale = Scale::between(&m, &separate);
                for (a, b) in m.scaled(&scale).merge.iter().zip(separate.merge) {
                    assert!((a - b).abs() <= 1e-9 * b, "scaled Mis(eta) {a}, own {b}");
                }
                let weight = |t: Tech| {
                    let from_parts = path.recursive_weight(&m, t, Some(&scale));
                    let own = path.recursive_weight(&separate, t, None);
                    let close = (from_parts - own).abs() <= 1e-5 * own.max(1e-3);
                    assert!(
                        close,
                        "{t:?} {factors:?}: from parts {from_parts}, own {own}"
                    );
                    if factors == [1.0; Merge::COUNT] {
                        assert_eq!(path.recursive_weight(&m, t, None), own);
                    }
                    own
                };
                let label = format!("{heuristic:?} vc={vc} {setup:?} radii x{factors:?}");
                check_path(&path, &scaled, setup, vc, &m, &weight, &label);
            }
        }
    }
}

/// The weights `weight` gives every technique on `path` against the explicit
/// heuristic over the estimators `merges`, and their sum.
fn check_path(
    path: &Path,
    merges: &Merges,
    setup: Setup,
    vc: bool,
    m: &Mis,
    weight: &dyn Fn(Tech) -> f32,
    label: &str,
) {
    let n = path.n;
    let techs = path.techniques(merges, vc, setup.merge_first, setup.first);
    if techs.is_empty() {
        return; // merging alone, where no estimator can sit on this path
    }
    let p = |t: Tech| m.f(path.density(t, merges, m.light_paths as f32));
    let total: f64 = techs.iter().map(|&t| p(t)).sum();
    let mut sum = 0.0;
    for &t in &techs {
        let expect = (p(t) / total) as f32;
        let got = weight(t);
        assert!(
            (got - expect).abs() <= 1e-4 * expect.max(1e-3),
            "{label} {merges:?} infinite={} n={n} {t:?}: recursive {got}, explicit {expect}",
            path.infinite
        );
        sum += got;
    }
    assert!((sum - 1.0).abs() < 1e-4, "{label}: weights sum to {sum}");
}

#[test]
fn vcm_weights_match_explicit_heuristics_and_sum_to_one() {
    for h in [Heuristic::Balance, Heuristic::Power] {
        check(h, true, merges(true, false), true, false);
        check(h, true, merges(true, false), false, false);
    }
}

#[test]
fn bpt_and_bpm_weights_sum_to_one() {
    for h in [Heuristic::Balance, Heuristic::Power] {
        check(h, true, merges(false, false), true, false);
        check(h, false, merges(true, false), true, false);
    }
}

/// Medium vertices and transmittances in the densities: the recursive weights with
/// d^2 / T and D in place of d^2 and the cosine are still the explicit heuristics,
/// with merging at surfaces only or with a second estimator of its own eta in media.
#[test]
fn weights_with_medium_vertices_match_explicit_heuristics_and_sum_to_one() {
    for h in [Heuristic::Balance, Heuristic::Power] {
        check(h, true, merges(false, false), true, true);
        for volume in [false, true] {
            check(h, true, merges(true, volume), true, true);
            check(h, true, merges(true, volume), false, true);
            check(h, false, merges(true, volume), true, true);
        }
    }
}

/// Every subset of [UPBP]'s estimators, with and without connections: the weights
/// of all techniques that can produce a path (connections, and each estimator at
/// each vertex where it can sit: surfaces, medium points, camera beams through
/// photon points, beams meeting at a sine above MIN_BEAM_SIN) are the explicit
/// heuristics and sum to one.
#[test]
fn upbp_weights_match_explicit_heuristics_and_sum_to_one() {
    for h in [Heuristic::Balance, Heuristic::Power] {
        for mask in 0..(1 << Merge::COUNT) {
            check(h, true, upbp(mask), true, true);
            check(h, true, upbp(mask), false, true);
            if mask != 0 {
                check(h, false, upbp(mask), true, true);
            }
        }
    }
}

/// Correlation-aware weights (Grittmann et al. 2021) from the explicit densities:
/// each rho in (0, 1], 1 at the first camera vertex; the weights of every technique
/// that can sample a path sum to one; and since rho only lowers merge densities, the
/// merges' total weight never grows.
#[test]
fn correlation_aware_weights_sum_to_one_and_never_favour_merges() {
    let mut rng = Rng::new(7, 2, 9);
    let mut lowered = 0;
    for (mask, media) in [(1u32, false), (0b1111, true), (0b0011, true)] {
        let merges = upbp(mask);
        for n in 2..7 {
            for k in 0..40 {
                let path = random_path(&mut rng, n, media, k % 2 == 1);
                for j in 0..n {
                    let rho = path.correlation(j, 1000.0);
                    assert!(rho > 0.0 && rho <= 1.0 + 1e-12, "rho_{j} = {rho}");
                    if j == n - 1 {
                        assert_eq!(rho, 1.0);
                    }
                }
                for h in [Heuristic::Balance, Heuristic::Power] {
                    let techs = path.techniques(&merges, true, true, false);
                    let w = |t, c| path.weight(t, &techs, (&merges, 1000.0), h, c);
                    let sum: f64 = techs.iter().map(|&t| w(t, true)).sum();
                    assert!((sum - 1.0).abs() < 1e-9, "{techs:?}: {sum}");
                    let merged = |c| {
                        let m = techs.iter().filter(|t| matches!(t, Tech::Merge(..)));
                        m.map(|&t| w(t, c)).sum::<f64>()
                    };
                    let (with, without) = (merged(true), merged(false));
                    assert!(with <= without * (1.0 + 1e-9), "{with} > {without}");
                    lowered += usize::from(with < without * (1.0 - 1e-6));
                }
            }
        }
    }
    // Not vacuous: on some paths the factors do move weight.
    assert!(lowered > 0);
}

/// rho's limits, on a path built for them: where the camera subpath surely reaches
/// the merge's neighbourhood (every acceptance 1) there is no penalty, and where the
/// light subpath surely does, rho is the camera's acceptance probability.
#[test]
fn correlation_factor_limits() {
    let mut rng = Rng::new(1, 1, 1);
    let mut path = random_path(&mut rng, 4, false, false);
    // A footprint radius of tan(1 deg) * 10.
    path.d2[3] = 100.0;
    let area = std::f64::consts::PI * (0.017_455_064_928_217_585f64 * 10.0).powi(2);
    // Camera-side densities huge, light-side tiny: cam = 1.
    path.camera = 1e9;
    path.pc = vec![1e9; 5];
    path.pl = vec![1e-9; 5];
    assert!((path.correlation(1, 1e30) - 1.0).abs() < 1e-12);
    // Light-side densities huge: light = 1, rho = cam.
    path.pc = vec![1e-3; 5];
    path.pl = vec![1e9; 5];
    (path.pick, path.e_pos, path.e_dir) = (1.0, 1e9, 1e9);
    let cam: f64 = (1..4)
        .map(|i| (path.bwd(i) as f64 * area).min(1.0))
        .product();
    assert!(cam < 1.0);
    let rho = path.correlation(1, 1e30);
    assert!((rho - cam).abs() <= 1e-9 * cam, "rho {rho}, cam {cam}");
}

#[test]
fn mis_transmittance_is_clamped() {
    assert_eq!(transmittance(0.0), 1.0);
    assert!((transmittance(2.0) - (-2.0f32).exp()).abs() < 1e-7);
    let floor = transmittance(MAX_MIS_DEPTH);
    assert!(floor > 0.0);
    assert_eq!(transmittance(f32::INFINITY), floor);
    assert_eq!(transmittance(f32::NAN), floor);
}

impl Path {
    /// Technique `t`'s weight in a pixel whose candidate is `c` (bidir::selection):
    /// under the candidate's MIS where it keeps `t`, else by the rule for dropped
    /// merges; checks that where the camera side rules such merges out (so the
    /// renderer skips them) the rule gives 0.
    fn candidate_weight(&self, m: &Mis, c: &Candidate, t: Tech) -> f32 {
        let Tech::Merge(j, k) = t else {
            return self.recursive_weight(m, t, Some(&c.scale));
        };
        if c.keeps(k) {
            return self.recursive_weight(m, t, Some(&c.scale));
        }
        let (qc, _, seen, cparts) = self.camera_q(m, j);
        let medium = self.site[j] == Site::Medium;
        let cuts = if medium { m.first_medium } else { m.cuts(seen) };
        let (ql, vol, lparts) = self.light_q(m, j);
        let (ql, lparts) = match cuts {
            true => (m.cut(ql, vol), lparts.without_media()),
            false => (ql, lparts),
        };
        let weight = |mis: &Mis, ql, qc| {
            let own = mis.eta(k, self.sigma(j), self.sin[j], self.tr[j]);
            mis.weight_merge(ql, qc, (own, self.vm(mis, j, None)), self.pc[j], self.pl[j])
        };
        let sides = |s: &Scale| (m.rescale(ql, &lparts, s), m.rescale(qc, &cparts, s));
        let w = Rule::Dropped(c).weight(k, (ql, qc), sides, weight, m);
        let site: &[Merge] = match self.site[j] {
            Site::Surface => &[Merge::Surface],
            Site::Medium => &MEDIA,
        };
        let uses = |j: Merge| m.merge[j as usize] > 0.0;
        let kept_here = site
            .iter()
            .any(|&j| j != Merge::BeamBeam1d && uses(j) && c.keeps(j));
        if camera_rules_out(c, m.rescale(qc, &cparts, &c.scale), kept_here) {
            assert_eq!(w, 0.0, "{t:?} is skipped but weighs {w}");
        }
        w
    }
}

/// Per-pixel candidates (efficiency-aware selection): for every upbp estimator set,
/// with and without connections, and every subset of it kept, the weights of all
/// techniques sum to one; where a kept technique can sample the path they are the
/// explicit heuristic over the kept ones (dropped merges 0), and where none can, the
/// job's own.
#[test]
fn candidate_weights_sum_to_one_and_drop_only_what_is_covered() {
    let mut rng = Rng::new(5, 3, 8);
    let (mut covered, mut uncovered) = (0, 0);
    for vc in [true, false] {
        for mask in 1..(1u32 << Merge::COUNT) {
            let merges = upbp(mask);
            let mut m = Mis::new(Heuristic::Balance, 1000.0, vc, merges);
            m.first_medium = mask % 3 == 0;
            for keep in 0..(1u32 << Merge::COUNT) {
                let keep = ALL_MERGES.map(|k| keep & (1 << k as u32) != 0);
                let c = Candidate::new(&m, keep);
                for n in 2..6 {
                    let path = random_path(&mut rng, n, true, n % 2 == 0);
                    let techs = path.techniques(&merges, vc, true, m.first_medium);
                    if techs.is_empty() {
                        continue;
                    }
                    let kept = |t: &Tech| !matches!(t, Tech::Merge(_, k) if !keep[*k as usize]);
                    let p = |t: Tech| m.f(path.density(t, &merges, 1000.0));
                    let kept_total: f64 = techs.iter().filter(|t| kept(t)).map(|&t| p(t)).sum();
                    let total: f64 = techs.iter().map(|&t| p(t)).sum();
                    let mut sum = 0.0;
                    for &t in &techs {
                        let got = path.candidate_weight(&m, &c, t);
                        let expect = match (kept_total > 0.0, kept(&t)) {
                            (true, true) => p(t) / kept_total,
                            (true, false) => 0.0,
                            (false, _) => p(t) / total,
                        } as f32;
                        assert!(
                            (got - expect).abs() <= 1e-4 * expect.max(1e-3),
                            "vc={vc} {merges:?} keep {keep:?} n={n} {t:?}: {got}, explicit {expect}"
                        );
                        sum += got;
                    }
                    assert!(
                        (sum - 1.0).abs() < 1e-4,
                        "keep {keep:?}: weights sum to {sum}"
                    );
                    match kept_total > 0.0 {
                        true => covered += 1,
                        false => uncovered += 1,
                    }
                }
            }
        }
    }
    // Both cases occur: paths the kept techniques sample, and paths they cannot.
    eprintln!("covered {covered}, uncovered {uncovered}");
    assert!(covered > 100 && uncovered > 100, "{covered} {uncovered}");
}
