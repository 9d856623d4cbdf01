//! The renderer's correlation-aware weights ([`crate::integrator::paths::correlation`]:
//! the recursion's weights with each side's [`Fix`], from links built as the subpaths
//! build them) against the explicit ones of [`Path::weight`], for every technique.
use super::*;
use crate::integrator::paths::correlation::{Carry, Chain, Fix, Footprint, Link};

const INF: f32 = f32::INFINITY;

impl Path {
    /// The light subpath's links of x_1 ..= x_k, as it stores them: the carry
    /// through each scatter and hit, each link's reverse density set by its scatter.
    fn light_links(&self, m: &Mis, k: usize) -> Vec<Link> {
        let (origin, dir, cos0) = if self.infinite {
            (INF, self.e_pos, 1.0)
        } else {
            (self.pick * self.e_pos, self.e_dir, self.cf[0])
        };
        let mut c = Carry::start(dir, cos0, origin);
        let mut pending = 0.0;
        let mut links: Vec<Link> = Vec::new();
        for i in 1..=k {
            let hit = (self.seg(i - 1), self.tr[i - 1], self.cb[i]);
            let link = m.carry_hit(c, pending, hit, self.site[i] == Site::Medium);
            c = link.carry_on();
            links.push(link);
            if i == k {
                break;
            }
            let (points, beams) = m.merge_parts(self.site[i], self.sigma(i), self.sin[i], None);
            let terms = m.unsettled_terms(self.site[i], self.sigma(i), self.sin[i], None);
            let (_, later) = m.defer_terms(terms, self.cf[i], self.pl[i]);
            let vm = if m.long_query { points } else { points + beams };
            links[i - 1].back_pdf = self.pc[i];
            c = m.carry_scatter(c, vm, self.cf[i], self.pl[i], self.pc[i], false);
            pending = later.sum();
        }
        links
    }

    /// The camera subpath's links of x_{n-1} down to x_k; for k = 0 the last one is
    /// the light's, which the camera subpath does not store.
    fn camera_links(&self, m: &Mis, k: usize) -> Vec<Link> {
        let n = self.n;
        let mut c = Carry::start(self.camera, 1.0, INF);
        let hit = (self.seg(n - 1), self.tr[n - 1], self.cf[n - 1]);
        let mut links = vec![m.carry_hit(c, 0.0, hit, self.site[n - 1] == Site::Medium)];
        c = links[0].carry_on();
        let (mut len, mut seen) = (1, false);
        for i in (k.max(1)..n).rev() {
            if i == k {
                break;
            }
            let vm = self.camera_vm(m, i, len, seen);
            seen |= self.site[i] == Site::Medium;
            links.last_mut().unwrap().back_pdf = self.pl[i];
            c = m.carry_scatter(c, vm, self.cb[i], self.pc[i], self.pl[i], false);
            let cos = if i == 1 && self.infinite {
                1.0
            } else {
                self.cf[i - 1]
            };
            let hit = (self.seg(i - 1), self.tr[i - 1], cos);
            let link = m.carry_hit(c, 0.0, hit, self.site[i - 1] == Site::Medium);
            len += 1;
            c = link.carry_on();
            links.push(link);
        }
        links
    }

    /// Both sides' fixes for technique `t`.
    fn fixes(&self, m: &Mis, t: Tech) -> (Fix, Fix) {
        let n = self.n;
        let fp = Footprint::new(self.d2[n - 1].sqrt());
        let accept = |i: usize, p: f32| fp.accept(p, self.site[i] == Site::Medium);
        let origin = if self.infinite {
            1.0
        } else {
            accept(0, self.pick * self.e_pos)
        };
        let (light, cam_chain) = (|l, r| chain(l, r, false), |l, r| chain(l, r, true));
        match t {
            Tech::Connect(0) => {
                let mut links = self.camera_links(m, 0);
                let tail = links.pop();
                let rev = if self.infinite {
                    self.e_pos
                } else {
                    self.e_dir
                };
                let chain = Chain {
                    tail,
                    ..cam_chain(&links, rev)
                };
                (Fix::NONE, chain.fix(m, &fp, origin))
            }
            Tech::Connect(1) => {
                let links = self.camera_links(m, 1);
                let chain = cam_chain(&links, self.pl[1]);
                (
                    Fix::NONE,
                    chain.fix(m, &fp, origin * accept(1, self.fwd(1))),
                )
            }
            Tech::Connect(s) if s == n => {
                let links = self.light_links(m, n - 1);
                let chain = light(&links, self.pc[n - 1]);
                let fix = chain.fix(m, &fp, accept(n - 1, self.bwd(n - 1)));
                (Fix { rho: 1.0, ..fix }, Fix::NONE)
            }
            Tech::Connect(s) => {
                let (ll, cl) = (self.light_links(m, s - 1), self.camera_links(m, s));
                let (lc, cc) = (light(&ll, self.pc[s - 1]), cam_chain(&cl, self.pl[s]));
                let (lt, ct) = (lc.total(&fp), cc.total(&fp));
                let lf = lc.fix(m, &fp, ct * accept(s - 1, self.bwd(s - 1)));
                let cf = cc.fix(m, &fp, lt * accept(s, self.fwd(s)));
                (lf, cf)
            }
            Tech::Merge(j, _) => {
                let (ll, cl) = (self.light_links(m, j), self.camera_links(m, j));
                let (lc, cc) = (light(&ll, self.pc[j]), cam_chain(&cl, self.pl[j]));
                let (lt, ct) = (lc.total(&fp), cc.total(&fp));
                (lc.fix(m, &fp, ct), cc.fix(m, &fp, lt))
            }
        }
    }
}

fn chain(links: &[Link], last_rev: f32, camera: bool) -> Chain<'_> {
    Chain {
        links,
        tail: None,
        last_rev,
        camera,
    }
}

/// Every technique's weight from the recursion and the fixes equals the explicit
/// correlation-aware weight, for surface and media estimators, short and long query
/// beams, with and without connections and merges at the first camera vertex; on
/// paths of 2 to 7 vertices and of 36 (beyond the 32 links whose acceptance
/// products the evaluator keeps at hand).
#[test]
fn fixed_recursive_weights_are_the_explicit_correlation_aware_ones() {
    let mut rng = Rng::new(5, 3, 2);
    let light_paths = 1000.0f32;
    let mut lowered = 0;
    for h in [Heuristic::Balance, Heuristic::Power] {
        for (mask, media, vc) in [
            (1u32, false, true),
            (1, false, false),
            (0b1111, true, true),
            (0b0011, true, true),
            (0b1101, true, false),
        ] {
            let merges = upbp(mask);
            for (long, merge_first) in [(false, true), (true, true), (false, false)] {
                let mut m = Mis::new(h, light_paths, vc, merges);
                (m.long_query, m.merge_first) = (long, merge_first);
                for n in (2..8).chain([36]) {
                    for k in 0..30 {
                        let mut path = random_path(&mut rng, n, media, k % 2 == 1);
                        path.long = long;
                        let techs = path.techniques(&merges, vc, merge_first, false);
                        let mut sum = 0.0;
                        for &t in &techs {
                            let w = |c| path.weight(t, &techs, (&merges, light_paths), h, c);
                            let expect = w(true) as f32;
                            let got = path.fixed_weight(&m, t, None, path.fixes(&m, t));
                            let label = format!("{h:?} mask {mask} vc {vc} long {long} first {merge_first} n {n} inf {} {t:?}", path.infinite);
                            assert!(
                                (got - expect).abs() <= 2e-4 * expect.max(1e-3),
                                "{label}: fixed {got}, explicit {expect}"
                            );
                            lowered += usize::from(expect < w(false) as f32 * 0.99);
                            sum += got as f64;
                        }
                        if !techs.is_empty() {
                            assert!((sum - 1.0).abs() < 1e-3, "weights sum to {sum}");
                        }
                    }
                }
            }
        }
    }
    // Not vacuous: rho moves weight on many paths.
    assert!(lowered > 100, "{lowered}");
}
