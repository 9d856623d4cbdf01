//! Correlation-aware MIS (Grittmann, Georgiev, Slusallek, EG 2021) in the renderer:
//! the O(n) evaluator that [`super::full_path`] defines explicitly.
//!
//! A merge at x_j has its density scaled by rho_j (the factor of
//! [`super::full_path::FullPath::correlation`]), which depends on both whole subpaths,
//! so the O(1) recursion of [`super::partial`] cannot carry it. It can carry
//! everything else: the recursion's dvc (and dvm) at a subpath's last vertex is a sum
//! of one term per technique, and the terms of the merges at the subpath's earlier
//! vertices x_i enter it with weight 1. Correlation-aware weights are therefore the
//! recursion's weights with each such term scaled by Mis(rho_i), i.e. dvc and dvm less
//! D = sum_i (1 - Mis(rho_i)) term_i, and the junction vertex's M(x) times its own
//! Mis(rho). This module finds D in O(n) from a [`Link`] per stored vertex: each link
//! keeps its predecessor's term as valued at the link (merges at a vertex are added at
//! its scatter and carried by the same factors as dvc), the factor that carries older
//! terms on, and the densities the acceptance probabilities of rho need.
//!
//! Specular vertices are never stored and never merge. They and every vertex sampled
//! from one have acceptance 1 (a delta density is as concentrated as a density can
//! be): a rule both subpaths apply alike, so every technique evaluates the same rho and
//! the weights still sum to one.

use super::partial::{Mis, Partial};

/// tan(1 degree): the surrogate acceptance radius per unit length of the first
/// camera segment (Grittmann et al.'s choice: a pixel's footprint grows with it).
pub(crate) const FOOTPRINT: f64 = 0.017_455_064_928_217_585;

/// What a stored subpath vertex keeps for the correlation factors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Link {
    /// The merges' terms of the previous stored vertex of the subpath, valued in this
    /// vertex's dvc (0: none).
    pub term: f64,
    /// The factor that carries the terms in the previous stored vertex's dvc to this
    /// one's.
    pub step: f64,
    /// The vertex's density from its own subpath (area measure at surfaces, volume in
    /// media, with the MIS transmittance; infinite after a specular vertex).
    pub own: f32,
    /// Turns a solid-angle density at this vertex towards the previous vertex into that
    /// vertex's area or volume density (its D times T / d^2 of the segment; infinite
    /// when the previous vertex is specular or the subpath's origin at infinity).
    pub back_geo: f32,
    /// This vertex's own density of sampling the previous vertex (solid angle, set once
    /// it scatters; infinite after a specular bounce).
    pub back_pdf: f32,
    /// The origin's density when this is the subpath's first stored vertex: pick times
    /// the emitted position's density (infinite for lights at infinity or with a delta
    /// position, and on camera subpaths, whose origin never counts).
    pub origin: f32,
    /// A medium vertex, whose footprint is a volume.
    pub medium: bool,
    /// The subpath's first stored vertex.
    pub first: bool,
}

/// What a subpath carries from its last stored vertex to fill the next [`Link`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Carry {
    pub term: f64,
    pub step: f64,
    /// Solid-angle density of the direction being traced (infinite after a specular
    /// bounce), or at a light at infinity the density on its disk.
    pub dir: f32,
    /// D at the vertex the segment leaves (1 at a light at infinity or the camera).
    pub cos_out: f32,
    /// Whether the vertex the segment leaves is specular.
    pub delta: bool,
    /// That vertex's density of sampling its predecessor (for its link's
    /// `back_pdf`; infinite when specular).
    pub rev: f32,
    pub origin: f32,
    pub first: bool,
}

impl Carry {
    /// A subpath leaving its origin along a direction of density `dir` (see the
    /// fields) from a point with D `cos_out`.
    pub fn start(dir: f32, cos_out: f32, origin: f32) -> Self {
        Carry {
            term: 0.0,
            step: 1.0,
            dir,
            cos_out,
            delta: false,
            rev: f32::INFINITY,
            origin,
            first: true,
        }
    }
}

impl Mis {
    /// The carry through a scatter whose merges sum to `vm` (terms deferred by
    /// [`Mis::defer_terms`] excluded), as [`Mis::on_scatter`] moves dvc.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn carry_scatter(
        &self,
        c: Carry,
        vm: f64,
        cos_out: f32,
        pdf_dir: f32,
        pdf_rev: f32,
        delta: bool,
    ) -> Carry {
        let g = self.f(cos_out as f64 / pdf_dir as f64);
        let r = self.f(pdf_rev);
        let term = if delta { c.term * r } else { c.term * r + vm };
        Carry {
            term: g * term,
            step: g * r * c.step,
            dir: if delta { f32::INFINITY } else { pdf_dir },
            cos_out,
            delta,
            rev: if delta { f32::INFINITY } else { pdf_rev },
            ..c
        }
    }

    /// The segment reaches a vertex with D `cos` (`seg` = d^2 / T, T = `tr`, as
    /// [`Mis::light_hit`] takes them, with the deferred terms `pending`): the link
    /// the vertex would store, and the carry it continues with once stored.
    #[inline]
    pub fn carry_hit(
        &self,
        c: Carry,
        pending: f64,
        (seg, tr, cos): (f32, f32, f32),
        medium: bool,
    ) -> Link {
        Link {
            term: self.hit_share(c.term, pending, tr, cos),
            step: c.step / self.f(cos),
            own: c.dir * cos / seg,
            back_geo: if c.delta {
                f32::INFINITY
            } else {
                c.cos_out / seg
            },
            back_pdf: f32::INFINITY,
            origin: c.origin,
            medium,
            first: c.first,
        }
    }
}

impl Link {
    /// The carry after this link's vertex is stored: its terms start anew.
    pub fn carry_on(&self) -> Carry {
        Carry {
            term: 0.0,
            step: 1.0,
            dir: f32::INFINITY,
            cos_out: 1.0,
            delta: false,
            rev: f32::INFINITY,
            origin: f32::INFINITY,
            first: false,
        }
    }

    /// The link of a vertex the subpath does not store (a specular one): the carry
    /// goes on through it.
    pub fn carry_through(&self, c: &Carry) -> Carry {
        Carry {
            term: self.term,
            step: self.step,
            first: self.first,
            origin: self.origin,
            ..*c
        }
    }
}

/// Where a light segment's flight began, for the correlation factors of a point on
/// it: the carry after that vertex's scatter, and the range of its subpath's links
/// stored before the flight, within their chunk.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FlightLinks {
    pub carry: Carry,
    pub links: (u32, u32),
}

impl FlightLinks {
    /// What flights that need no links carry.
    pub const NONE: FlightLinks = FlightLinks {
        carry: Carry {
            term: 0.0,
            step: 1.0,
            dir: 0.0,
            cos_out: 0.0,
            delta: false,
            rev: 0.0,
            origin: 0.0,
            first: true,
        },
        links: (0, 0),
    };
}

/// The surrogate acceptance footprint of a camera subpath whose first segment is
/// `first_segment` long: a disc at surfaces, a ball in media.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Footprint {
    area: f64,
    volume: f64,
}

impl Footprint {
    pub fn new(first_segment: f32) -> Self {
        let r = FOOTPRINT * first_segment as f64;
        let pi = std::f64::consts::PI;
        Footprint {
            area: pi * r * r,
            volume: 4.0 / 3.0 * pi * r * r * r,
        }
    }

    /// The probability that a subpath sampling a vertex with density `p` lands in
    /// its footprint (1 for a delta density).
    #[inline]
    pub fn accept(&self, p: f32, medium: bool) -> f64 {
        if p == f32::INFINITY {
            return 1.0;
        }
        let v = if medium { self.volume } else { self.area };
        (p as f64 * v).min(1.0)
    }
}

/// A light's origin as the acceptance probabilities see it: pick times its
/// position's density (infinite, i.e. always accepted, for a light at infinity or with
/// a delta position), and the density that samples the first segment (the emitted
/// direction's, or at infinity the position's on the light's disk), from the
/// emission's densities `pos` and `dir`.
#[inline]
pub(crate) fn light_origin(
    infinite: bool,
    delta: bool,
    pick: f32,
    (pos, dir): (f32, f32),
) -> (f32, f32) {
    match (infinite, delta) {
        (true, _) => (f32::INFINITY, pos),
        (false, true) => (f32::INFINITY, dir),
        (false, false) => (pick * pos, dir),
    }
}

/// The correlation factor from the camera's and the light's acceptance probabilities,
/// at least 1 / N (a merge has at least one light subpath's worth of samples).
#[inline]
pub(crate) fn rho(cam: f64, light: f64, light_paths: f64) -> f64 {
    if cam == 0.0 && light == 0.0 {
        return 1.0;
    }
    (cam / (cam + light - cam * light)).max(1.0 / light_paths)
}

/// One subpath's side of a technique: its stored vertices' links from the origin to
/// the junction vertex (the last, possibly a point no link was stored for, `tail`),
/// and the junction vertex's density of sampling its predecessor under the technique.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Chain<'a> {
    pub links: &'a [Link],
    pub tail: Option<Link>,
    pub last_rev: f32,
    /// The camera subpath (whose first vertex merges uncorrelated).
    pub camera: bool,
}

/// What a side's weights change by: dvc and dvm less `d`, the junction vertex's M(x)
/// times `rho` (Mis(rho) of the junction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Fix {
    pub d: f64,
    pub rho: f64,
}

impl Fix {
    #[cfg(test)]
    pub const NONE: Fix = Fix { d: 0.0, rho: 1.0 };

    /// The side's partial weights as the correlation-aware weights take them.
    #[inline]
    pub fn apply(&self, q: Partial) -> Partial {
        Partial {
            dvcm: q.dvcm,
            dvc: (q.dvc - self.d).max(0.0),
            dvm: (q.dvm - self.d).max(0.0),
        }
    }
}

impl Chain<'_> {
    fn len(&self) -> usize {
        self.links.len() + usize::from(self.tail.is_some())
    }

    fn at(&self, k: usize) -> &Link {
        match self.links.get(k) {
            Some(l) => l,
            None => self.tail.as_ref().expect("a link within the chain"),
        }
    }

    /// The product of the acceptance probabilities of the side's own densities of its
    /// vertices 0 ..= k (and of its origin).
    fn own(&self, fp: &Footprint, k: usize) -> f64 {
        let first = fp.accept(self.at(0).origin, false);
        (0..=k).fold(first, |p, i| {
            let l = self.at(i);
            p * fp.accept(l.own, l.medium)
        })
    }

    /// The side's own acceptance product over all its vertices.
    pub fn total(&self, fp: &Footprint) -> f64 {
        self.own(fp, self.len() - 1)
    }

    /// The side's fix, `other` being the other side's acceptance product at the
    /// junction vertex (the camera's for the light side and the converse, each with
    /// the crossing density of the junction vertex where the technique connects).
    pub fn fix(&self, mis: &Mis, fp: &Footprint, other: f64) -> Fix {
        self.fix_total(mis, fp, other).0
    }

    /// [`Chain::fix`] and [`Chain::total`] from one pass over the links.
    pub fn fix_total(&self, mis: &Mis, fp: &Footprint, other: f64) -> (Fix, f64) {
        let n = self.len();
        let rho_at = |k: usize, own: f64, other: f64| -> f64 {
            if self.camera && k == 0 {
                return 1.0;
            }
            let (cam, light) = if self.camera {
                (own, other)
            } else {
                (other, own)
            };
            mis.f(rho(cam, light, mis.light_paths))
        };
        // Own products from the origin, kept for the walk back from the junction.
        let mut prefix = [0.0f64; 32];
        let mut acc = fp.accept(self.at(0).origin, false);
        for (i, slot) in prefix.iter_mut().enumerate().take(n) {
            let l = self.at(i);
            acc *= fp.accept(l.own, l.medium);
            *slot = acc;
        }
        let own = |k: usize| if k < 32 { prefix[k] } else { self.own(fp, k) };
        let junction = rho_at(n - 1, own(n - 1), other);
        let (mut d, mut mult, mut q) = (0.0, 1.0, other);
        for k in (1..n).rev() {
            let l = self.at(k);
            let pdf = if k == n - 1 {
                self.last_rev
            } else {
                l.back_pdf
            };
            q *= fp.accept(pdf * l.back_geo, self.at(k - 1).medium);
            let t = mult * l.term;
            if t > 0.0 {
                d += (1.0 - rho_at(k - 1, own(k - 1), q)) * t;
            }
            mult *= l.step;
        }
        (Fix { d, rho: junction }, own(n - 1))
    }
}

/// Both sides' fixes of a merge that joins the light chain `lc` and the camera chain
/// `cc`, whose acceptance product is `ct` ([`Chain::total`]), at one vertex: the
/// merged point is both sides' own, so each side's acceptance at it is the other
/// side's whole product.
#[inline(always)]
pub(crate) fn merge_fixes(
    mis: &Mis,
    fp: &Footprint,
    lc: Chain,
    (cc, ct): (Chain, f64),
) -> (Fix, Fix) {
    let (fl, lt) = lc.fix_total(mis, fp, ct);
    (fl, cc.fix(mis, fp, lt))
}

/// A camera subpath's side of correlation-aware weights: its stored links (the
/// current vertex's last, if it is stored) and its footprint.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CameraSide<'a> {
    pub links: &'a [Link],
    pub fp: Footprint,
}

impl<'a> CameraSide<'a> {
    /// The chain to a junction vertex (`tail` when not stored), whose density of
    /// sampling its predecessor is `last_rev`.
    pub fn chain(&self, tail: Option<Link>, last_rev: f32) -> Chain<'a> {
        Chain {
            links: self.links,
            tail,
            last_rev,
            camera: true,
        }
    }
}

impl<'a> Chain<'a> {
    /// A light subpath's chain to its vertex `links.last()`.
    pub fn light(links: &'a [Link], last_rev: f32) -> Self {
        Chain {
            links,
            tail: None,
            last_rev,
            camera: false,
        }
    }
}
