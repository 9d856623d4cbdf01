//! What the bidirectional family takes: its technique sets, its parameters, and the
//! extra images it can split its estimate into.

use crate::integrator::estimators::beams::BeamForm;
use crate::integrator::paths::layers::Layers;
use crate::integrator::paths::partial::Merge;
use crate::integrator::paths::Tracing;
use crate::integrator::transport::params::{check_max_depth, check_radius, ParamError};
use crate::integrator::transport::Heuristic;
use serde::{Deserialize, Serialize};

/// Which techniques an iteration uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Technique {
    /// Light tracing: light subpaths splatted to the camera, no MIS.
    Lt,
    /// Bidirectional path tracing: every (s, t) connection.
    Bpt,
    /// Bidirectional photon mapping: merging at every non-specular camera vertex.
    Bpm,
    /// Connections and merging, all weighted together.
    Vcm,
    /// Unifying points, beams and paths (Křivánek et al. 2014): any subset of
    /// connections, surface photons and the three volume estimators, under one MIS.
    Upbp(Estimators),
}

/// The techniques of `upbp`: connections (bidirectional path tracing) and the four
/// merge estimators of [`Merge`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Estimators {
    pub bpt: bool,
    pub merge: [bool; Merge::COUNT],
}

impl Technique {
    pub(super) fn connects(self) -> bool {
        match self {
            Technique::Bpt | Technique::Vcm => true,
            Technique::Upbp(e) => e.bpt,
            _ => false,
        }
    }

    /// Whether estimator `k` is used (in scenes where it can sit).
    pub(super) fn uses(self, k: Merge) -> bool {
        match self {
            Technique::Bpm | Technique::Vcm => matches!(k, Merge::Surface | Merge::Point3d),
            Technique::Upbp(e) => e.merge[k as usize],
            _ => false,
        }
    }

    /// Light vertices are gathered by the surface or 3D point estimators.
    pub(super) fn merges(self) -> bool {
        self.uses(Merge::Surface) || self.uses(Merge::Point3d)
    }

    /// Light vertices are kept after the light pass.
    pub(super) fn stores(self) -> bool {
        self != Technique::Lt
    }

    /// Light vertices connect to the camera (splats).
    pub(crate) fn splats(self) -> bool {
        self.connects() || self == Technique::Lt
    }

    /// What the light tracer does for this technique.
    pub(crate) fn tracing(self) -> Tracing {
        Tracing {
            lt: self == Technique::Lt,
            stores: self.stores(),
            splats: self.splats(),
            merges: self.merges(),
        }
    }
}

/// One technique of `upbp`'s `techniques` parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UpbpTechnique {
    /// Every connection of bidirectional path tracing (light tracing included).
    Bpt,
    /// Photon points on surfaces, 2D kernel.
    Surf,
    /// Photon points at a camera point in a medium, 3D kernel.
    Pp3d,
    /// Photon points along a camera beam, 2D kernel.
    Pb2d,
    /// Photon beams along a camera beam, 1D kernel.
    Bb1d,
}

impl UpbpTechnique {
    pub const ALL: [UpbpTechnique; 5] = [
        UpbpTechnique::Bpt,
        UpbpTechnique::Surf,
        UpbpTechnique::Pp3d,
        UpbpTechnique::Pb2d,
        UpbpTechnique::Bb1d,
    ];

    /// The layer name of `technique_layers`.
    pub fn name(self) -> &'static str {
        match self {
            UpbpTechnique::Bpt => "bpt",
            UpbpTechnique::Surf => "surf",
            UpbpTechnique::Pp3d => "pp3d",
            UpbpTechnique::Pb2d => "pb2d",
            UpbpTechnique::Bb1d => "bb1d",
        }
    }
}

impl Estimators {
    pub fn from_list(list: &[UpbpTechnique]) -> Self {
        let mut e = Estimators {
            bpt: false,
            merge: [false; Merge::COUNT],
        };
        for t in list {
            match t {
                UpbpTechnique::Bpt => e.bpt = true,
                UpbpTechnique::Surf => e.merge[Merge::Surface as usize] = true,
                UpbpTechnique::Pp3d => e.merge[Merge::Point3d as usize] = true,
                UpbpTechnique::Pb2d => e.merge[Merge::PointBeam2d as usize] = true,
                UpbpTechnique::Bb1d => e.merge[Merge::BeamBeam1d as usize] = true,
            }
        }
        e
    }
}

/// Settings shared by `lt`, `bpt`, `bpm`, `vcm` and `upbp` (merging parameters only
/// matter to the merging ones, beam parameters to `upbp`).
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_depth` | 64 | longest path in segments, as Mitsuba's `max_depth` (SmallVCM's max path length) |
/// | `light_paths` | 1 | light subpaths per iteration, as a multiple of the pixel count |
/// | `radius` | none | initial surface merge radius in scene units; overrides `radius_factor` |
/// | `radius_factor` | 0.003 | initial surface merge radius as a fraction of the scene's bounding-sphere radius |
/// | `alpha` | 0.75 | its reduction: r_i = r_0 / i^((1 - alpha) / 2) |
/// | `medium_radius` | none | initial radius of merging in media (point x point 3D) in scene units; overrides `medium_radius_factor` |
/// | `medium_radius_factor` | 0.02 | the same as a fraction of the scene's bounding-sphere radius |
/// | `medium_alpha` | 4/7 | its reduction, r_{i+1}^3 = r_i^3 (i + alpha) / (i + 1) (Knaus and Zwicker; 4/7 balances variance and squared bias in 3D) |
/// | `pb2d_radius`, `pb2d_radius_factor`, `pb2d_alpha` | none, 0.01, 2/3 | `upbp`'s point x beam 2D radius, as the above, r^2 schedule |
/// | `bb1d_radius`, `bb1d_radius_factor`, `bb1d_alpha` | none, 0.005, 4/5 | `upbp`'s beam x beam 1D radius, as the above, r schedule |
/// | `query_beams` | `short` | `upbp`: camera segments gather only up to where the camera's free flight scattered (`short`), or along their whole length to the next surface, weighted by transmittance (`long`, SmallUPBP's default: the expected value of `short` over the flight, so less variance per iteration, at a cost that grows with the optical depth of the segments) |
/// | `long_beam_weights` | true | with `query_beams: long`, the MIS weighs query beams as long beams, whose density at a point is larger than a short one's by 1 / T of the camera segment up to it ([UPBP], SmallUPBP); false keeps the short beams' weights (also unbiased, a different partition) |
/// | `beam_paths` | 0.1 | `upbp`: the fraction of light subpaths whose segments through media become photon beams (SmallUPBP's `-pbc`) |
/// | `techniques` | all | `upbp`: any non-empty subset of `bpt`, `surf`, `pp3d`, `pb2d`, `bb1d`: a list, or a string `all` or `surf+pb2d` (SmallUPBP's `-a upbp_surf+pb2d`) |
/// | `merge_first` | true | merge at the first camera vertex (when false, that technique leaves the MIS too) |
/// | `merge_depth` | `first` | merges in media (`pp3d`, `pb2d`, `bb1d`; also `vcm`'s in media) at every camera segment and vertex (`all`), or only up to the camera's first scattering in a medium (`first`: where the path has no medium vertex between the merge and the camera, as a `vpm`-like first-segment estimate; those techniques also leave the MIS, so every path keeps the others) |
/// | `correlation_aware` | false | `bpm`, `vcm`, `upbp`: correlation-aware MIS (Grittmann et al. 2021): each merge's density scaled by rho = cam / (cam + light - cam light) from both subpaths' acceptance probabilities in a footprint of tan(1 deg) times the first camera segment (a disc at surfaces, a ball in media), so merges that reuse one light subpath for many pixels weigh less at deep camera vertices; weights evaluated in O(path length); every estimator, beams included (their rho at points on query beams and photon beams); needs `merge_depth: all` (rho is what `first` approximates); not yet with `radii` or `selection: adaptive` |
/// | `local_media_mis` | false | in heterogeneous media, MIS takes D = the grey sigma_t at each vertex and T from a 4-point quadrature of each segment's optical depth (deterministic, so unbiased), instead of 1 for both |
/// | `russian_roulette` | true | continue with probability max(albedo) at every vertex, as SmallVCM |
/// | `heuristic` | `balance` | MIS weights: `balance` or `power` |
/// | `max_vertex_mib` | 2048 | budget for stored light vertices (and segments) per iteration |
/// | `technique_layers` | false | `vcm`: EXR layers `vc` and `vm` with the connection-only and merging-only parts (thesis Table 5.5); `upbp`: one layer per technique |
/// | `depth_layers` | false | with `technique_layers`: each merge layer split by the camera vertex or segment the merge sits at: `<technique>_c1`, `_c2`, `_c3+` |
/// | `radii` | none | `bpm`, `vcm`, `upbp`: more initial surface merge radii in scene units (a list, or a string joined by `+` or spaces), each rendered into its own EXR layer `radius0`, `radius1`, ... in the same job, from the same light paths, connections and merge queries: layer i is the image the job would render with `radius: radii[i]` (up to float rounding; for `upbp`, whose `selection: auto` is adaptive, with `selection: all`, which a job with `radii` takes); at most 16 |
/// | `medium_radii` | none | with `radii`: the layers' initial medium merge radii (as `medium_radius`), one per radius; absent, every layer keeps the job's own |
/// | `pb2d_radii`, `bb1d_radii` | none | with `radii`: the layers' initial point x beam 2D and beam x beam 1D radii (as `pb2d_radius`, `bb1d_radius`), one per radius; absent, every layer keeps the job's own |
/// | `selection` | `auto` | `bpm`, `vcm`, `upbp`: every pixel merges with every estimator (`all`), or each pixel keeps the estimators that render it most efficiently (`adaptive`: second moments and merge counts measured at iterations 0, 3, 15, 63, ..., choices renewed after 4^j iterations; paths only a dropped estimator finds keep it, so the image stays unbiased; not with `radii` or `correlation_aware`); `auto` is `adaptive` for `upbp` (what measured best at equal time) unless `radii` or `correlation_aware` is given, and `all` otherwise |
/// | `strategy_images` | 0 | `bpt`/`vcm`/`lt`: one EXR layer `s<S>_t<T>` per connection strategy for path lengths up to this (0: off) |
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct BidirSettings {
    pub max_depth: u32,
    pub light_paths: f32,
    pub radius: Option<f32>,
    pub radius_factor: f32,
    pub alpha: f32,
    pub medium_radius: Option<f32>,
    pub medium_radius_factor: f32,
    pub medium_alpha: f32,
    pub pb2d_radius: Option<f32>,
    pub pb2d_radius_factor: f32,
    pub pb2d_alpha: f32,
    pub bb1d_radius: Option<f32>,
    pub bb1d_radius_factor: f32,
    pub bb1d_alpha: f32,
    pub query_beams: BeamForm,
    pub long_beam_weights: bool,
    pub beam_paths: f32,
    #[serde(deserialize_with = "de_techniques")]
    pub techniques: Vec<UpbpTechnique>,
    pub merge_first: bool,
    pub merge_depth: MergeDepth,
    pub selection: PixelSelection,
    pub correlation_aware: bool,
    pub local_media_mis: bool,
    pub russian_roulette: bool,
    pub heuristic: Heuristic,
    pub max_vertex_mib: f32,
    pub technique_layers: bool,
    pub depth_layers: bool,
    pub strategy_images: u32,
    #[serde(deserialize_with = "de_radii")]
    pub radii: Vec<f32>,
    #[serde(deserialize_with = "de_radii")]
    pub medium_radii: Vec<f32>,
    #[serde(deserialize_with = "de_radii")]
    pub pb2d_radii: Vec<f32>,
    #[serde(deserialize_with = "de_radii")]
    pub bb1d_radii: Vec<f32>,
}

/// The EXR layer of `radii[i]`.
pub fn radius_layer_name(i: usize) -> String {
    format!("radius{i}")
}

impl Default for BidirSettings {
    fn default() -> Self {
        BidirSettings {
            max_depth: 64,
            light_paths: 1.0,
            radius: None,
            radius_factor: 0.003,
            alpha: 0.75,
            medium_radius: None,
            medium_radius_factor: 0.02,
            medium_alpha: 4.0 / 7.0,
            pb2d_radius: None,
            pb2d_radius_factor: 0.01,
            pb2d_alpha: 2.0 / 3.0,
            bb1d_radius: None,
            bb1d_radius_factor: 0.005,
            bb1d_alpha: 0.8,
            query_beams: BeamForm::Short,
            long_beam_weights: true,
            beam_paths: 0.1,
            techniques: UpbpTechnique::ALL.to_vec(),
            merge_first: true,
            merge_depth: MergeDepth::First,
            selection: PixelSelection::Auto,
            correlation_aware: false,
            local_media_mis: false,
            russian_roulette: true,
            heuristic: Heuristic::Balance,
            max_vertex_mib: 2048.0,
            technique_layers: false,
            depth_layers: false,
            strategy_images: 0,
            radii: Vec::new(),
            medium_radii: Vec::new(),
            pb2d_radii: Vec::new(),
            bb1d_radii: Vec::new(),
        }
    }
}

/// Where along the camera subpath merges in media are techniques (`merge_depth`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MergeDepth {
    All,
    /// Up to the camera's first scattering in a medium.
    #[default]
    First,
}

/// Which merge estimators each pixel uses (`selection`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PixelSelection {
    /// `Adaptive` where the job can take it and it measured best (`upbp` without
    /// `radii` or `correlation_aware`), else `All`: [`BidirSettings::selection_for`].
    #[default]
    Auto,
    /// Every estimator of the technique, everywhere.
    All,
    /// Per pixel, chosen by efficiency from pilot iterations (`bidir::adaptive`).
    Adaptive,
}

/// `techniques`: a list of names, or one string, `all` or names joined by `+` (for
/// command lines and URLs, where a JSON list is awkward).
fn de_techniques<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<UpbpTechnique>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Form {
        List(Vec<UpbpTechnique>),
        Joined(String),
    }
    match Form::deserialize(d)? {
        Form::List(v) => Ok(v),
        Form::Joined(s) if s == "all" => Ok(UpbpTechnique::ALL.to_vec()),
        Form::Joined(s) => s
            .split('+')
            .map(|name| {
                UpbpTechnique::ALL
                    .into_iter()
                    .find(|t| t.name() == name)
                    .ok_or_else(|| {
                        serde::de::Error::custom(format!(
                            "unknown technique `{name}`: expected bpt, surf, pp3d, pb2d or bb1d"
                        ))
                    })
            })
            .collect(),
    }
}

/// `radii`, `medium_radii`: a list of numbers, one number, or one string of numbers
/// joined by `+` or spaces (for command lines, where commas separate algorithms, and
/// URLs, where `+` is a space).
fn de_radii<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f32>, D::Error> {
    use serde::de::Error;
    let number = |t: &str| {
        t.parse::<f32>()
            .map_err(|_| D::Error::custom(format!("`{t}` is no radius: expected a number")))
    };
    match serde_json::Value::deserialize(d)? {
        serde_json::Value::Array(v) => v
            .iter()
            .map(|x| x.as_f64().map(|x| x as f32))
            .collect::<Option<Vec<f32>>>()
            .ok_or_else(|| D::Error::custom("expected a list of numbers")),
        serde_json::Value::Number(x) => Ok(vec![x.as_f64().unwrap_or(f64::NAN) as f32]),
        serde_json::Value::String(s) => s
            .split(|c: char| c == '+' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(number)
            .collect(),
        _ => Err(D::Error::custom("expected a list of numbers")),
    }
}

/// A radius reduction exponent in (0, 1], named.
fn check_alpha(name: &str, alpha: f32) -> Result<(), ParamError> {
    if alpha > 0.0 && alpha <= 1.0 {
        Ok(())
    } else {
        Err(ParamError::new(
            name,
            format!("{name} must be in (0, 1], got {alpha}"),
        ))
    }
}

impl BidirSettings {
    /// The technique this algorithm runs as (`upbp`'s from its `techniques`).
    /// The selection a job of `technique` renders with: `auto` resolved. Adaptive
    /// selection is `upbp`'s default because it measured best at equal time on five
    /// of the issue-39 scenes (1.3x to 2.4x the best single method's RMSE, against
    /// 2.2x to 5.2x with every estimator everywhere; scenes/media/bench-upbp-39).
    /// `bpm` and `vcm` keep every estimator: their adaptive selection was not
    /// measured against it. Nor is it combined with radius layers or correlation-aware
    /// weights, which it does not support yet.
    pub fn selection_for(&self, technique: Technique) -> PixelSelection {
        match self.selection {
            PixelSelection::Auto => {
                let upbp = matches!(technique, Technique::Upbp(_));
                let plain = self.radii.is_empty() && !self.correlation_aware;
                if upbp && plain && technique.merges() {
                    PixelSelection::Adaptive
                } else {
                    PixelSelection::All
                }
            }
            chosen => chosen,
        }
    }

    /// Whether `radii` changed what `auto` resolves to: the same job without them
    /// (a separate job of one radius) would select adaptively, so its image is not
    /// the radius layer's.
    pub fn radii_change_selection(&self, technique: Technique) -> bool {
        let single = BidirSettings {
            radii: Vec::new(),
            ..self.clone()
        };
        single.selection_for(technique) != self.selection_for(technique)
    }

    pub fn technique_of(&self, name: &str) -> Technique {
        match name {
            "lt" => Technique::Lt,
            "bpt" => Technique::Bpt,
            "bpm" => Technique::Bpm,
            "vcm" => Technique::Vcm,
            _ => Technique::Upbp(Estimators::from_list(&self.techniques)),
        }
    }

    pub fn validate(&self, technique: Technique) -> Result<(), ParamError> {
        check_max_depth(self.max_depth)?;
        if !(self.light_paths.is_finite() && self.light_paths > 0.0 && self.light_paths <= 64.0) {
            return Err(ParamError::new(
                "light_paths",
                format!("light_paths must be in (0, 64], got {}", self.light_paths),
            ));
        }
        check_radius(self.radius, self.radius_factor)?;
        check_alpha("alpha", self.alpha)?;
        for (name, r, f, a) in [
            (
                "medium",
                self.medium_radius,
                self.medium_radius_factor,
                self.medium_alpha,
            ),
            (
                "pb2d",
                self.pb2d_radius,
                self.pb2d_radius_factor,
                self.pb2d_alpha,
            ),
            (
                "bb1d",
                self.bb1d_radius,
                self.bb1d_radius_factor,
                self.bb1d_alpha,
            ),
        ] {
            check_radius(r, f).map_err(|e| e.prefixed(&format!("{name}_")))?;
            check_alpha(&format!("{name}_alpha"), a)?;
        }
        if !(self.beam_paths > 0.0 && self.beam_paths <= 1.0) {
            return Err(ParamError::new(
                "beam_paths",
                format!("beam_paths must be in (0, 1], got {}", self.beam_paths),
            ));
        }
        if !(self.max_vertex_mib.is_finite() && self.max_vertex_mib > 0.0) {
            return Err(ParamError::new(
                "max_vertex_mib",
                format!(
                    "max_vertex_mib must be positive, got {}",
                    self.max_vertex_mib
                ),
            ));
        }
        if self.strategy_images > MAX_STRATEGY_LENGTH {
            return Err(ParamError::new(
                "strategy_images",
                format!(
                    "strategy_images covers path lengths up to {MAX_STRATEGY_LENGTH}, got {}",
                    self.strategy_images
                ),
            ));
        }
        let upbp = matches!(technique, Technique::Upbp(_));
        if self.technique_layers && !(upbp || technique == Technique::Vcm) {
            return Err(ParamError::new(
                "technique_layers",
                "technique_layers (one layer per technique) needs vcm or upbp",
            ));
        }
        if self.depth_layers && !self.technique_layers {
            return Err(ParamError::new(
                "depth_layers",
                "depth_layers splits the technique layers: it needs technique_layers",
            ));
        }
        if !self.merge_first && technique == Technique::Bpm {
            return Err(ParamError::new(
                "merge_first",
                "merge_first: false leaves bpm no technique for light seen after one bounce; use vcm",
            ));
        }
        self.check_radii(technique)?;
        self.check_correlation(technique)?;
        if upbp {
            self.check_techniques()?;
        } else if self.techniques != UpbpTechnique::ALL {
            return Err(ParamError::new(
                "techniques",
                "techniques chooses upbp's techniques; use upbp",
            ));
        }
        Ok(())
    }

    /// `radii` and `medium_radii`: positive, finite, at most MAX_RADII, with a
    /// technique that merges where they apply.
    fn check_radii(&self, technique: Technique) -> Result<(), ParamError> {
        let lists = [
            ("radii", &self.radii),
            ("medium_radii", &self.medium_radii),
            ("pb2d_radii", &self.pb2d_radii),
            ("bb1d_radii", &self.bb1d_radii),
        ];
        for (name, list) in lists {
            if let Some(r) = list.iter().find(|r| !(r.is_finite() && **r > 0.0)) {
                let message = format!("{name} must be positive and finite, got {r}");
                return Err(ParamError::new(name, message));
            }
        }
        let n = self.radii.len();
        if n > MAX_RADII {
            let message = format!("radii lists at most {MAX_RADII} radii, got {n}");
            return Err(ParamError::new("radii", message));
        }
        for (name, list) in &lists[1..] {
            if !list.is_empty() && list.len() != n {
                let m = list.len();
                let message = format!("{name} needs one radius per radii entry ({n}), got {m}");
                return Err(ParamError::new(*name, message));
            }
        }
        let adaptive = self.selection == PixelSelection::Adaptive;
        if adaptive && !technique.merges() {
            let message = "selection: adaptive chooses merge estimators: it needs bpm, vcm or upbp";
            return Err(ParamError::new("selection", message));
        }
        if n == 0 {
            return Ok(());
        }
        if !technique.merges() {
            let message = "radii are merge radii: they need bpm, vcm or upbp";
            return Err(ParamError::new("radii", message));
        }
        if adaptive {
            let message = "selection: adaptive renders no radius layers; leave radii out";
            return Err(ParamError::new("selection", message));
        }
        Ok(())
    }

    /// `correlation_aware`: with a merging technique and what its evaluator covers.
    fn check_correlation(&self, technique: Technique) -> Result<(), ParamError> {
        if !self.correlation_aware {
            return Ok(());
        }
        let problem = if !technique.merges() {
            "correlation_aware scales merges' weights: it needs bpm, vcm or upbp"
        } else if self.merge_depth != MergeDepth::All {
            "correlation_aware weighs merges at every camera vertex (what merge_depth: first approximates): set merge_depth: all"
        } else if !self.radii.is_empty() || self.selection == PixelSelection::Adaptive {
            "correlation_aware is not combined with radii or selection: adaptive yet"
        } else {
            return Ok(());
        };
        Err(ParamError::new("correlation_aware", problem))
    }

    /// Layer `i`'s initial radius of each estimator, where its lists set one (else
    /// the job's own: None where the job derives it from the scene).
    pub fn layer_radii(&self, i: usize) -> [Option<f32>; Merge::COUNT] {
        let own = |list: &[f32], job: Option<f32>| list.get(i).copied().or(job);
        [
            self.radii.get(i).copied(),
            own(&self.medium_radii, self.medium_radius),
            own(&self.pb2d_radii, self.pb2d_radius),
            own(&self.bb1d_radii, self.bb1d_radius),
        ]
    }

    fn check_techniques(&self) -> Result<(), ParamError> {
        let refuse = |message: String| Err(ParamError::new("techniques", message));
        if self.techniques.is_empty() {
            return refuse(
                "techniques must name at least one of bpt, surf, pp3d, pb2d, bb1d".into(),
            );
        }
        for (i, t) in self.techniques.iter().enumerate() {
            if self.techniques[..i].contains(t) {
                return refuse(format!("techniques names {} twice", t.name()));
            }
        }
        if !self.merge_first && !self.techniques.contains(&UpbpTechnique::Bpt) {
            return Err(ParamError::new(
                "merge_first",
                "merge_first: false without bpt leaves no technique for light seen after one bounce",
            ));
        }
        Ok(())
    }
}

impl BidirSettings {
    /// The extra images a job of `technique` writes (`technique_layers`,
    /// `strategy_images`).
    pub fn layer_count(&self, technique: Technique) -> usize {
        Layers::new(self, technique).names.len()
    }
}

/// Camera depths `depth_layers` tells apart: merges at camera vertex or segment 1, 2,
/// and 3 or more.
const DEPTH_BINS: u32 = 3;

/// Most `radii` one job renders.
pub const MAX_RADII: usize = 16;

/// Longest path with per-strategy images (lengths 1..=8 give 44 layers).
pub const MAX_STRATEGY_LENGTH: u32 = 8;

impl Layers {
    pub(super) fn new(s: &BidirSettings, technique: Technique) -> Self {
        let mut layers = Layers {
            strategies: if s.technique_layers {
                0
            } else {
                s.strategy_images
            },
            techniques: s.technique_layers,
            ..Default::default()
        };
        if s.technique_layers {
            let merges: Vec<&str> = if let Technique::Upbp(_) = technique {
                // One layer per technique, whether used or not: bpt surf pp3d pb2d bb1d.
                UpbpTechnique::ALL[1..].iter().map(|t| t.name()).collect()
            } else {
                vec!["vm"]
            };
            let connections = if merges.len() > 1 { "bpt" } else { "vc" };
            layers.names.push(connections.to_string());
            layers.depths = if s.depth_layers { DEPTH_BINS } else { 1 };
            for name in &merges {
                if s.depth_layers {
                    let bins = (1..DEPTH_BINS).map(|c| format!("{name}_c{c}"));
                    layers.names.extend(bins);
                    layers.names.push(format!("{name}_c{DEPTH_BINS}+"));
                } else {
                    layers.names.push(name.to_string());
                }
            }
            // Merge estimator k's first layer (vcm's two share one).
            let per = layers.depths as usize;
            layers.merges = std::array::from_fn(|k| (1 + per * k.min(merges.len() - 1)) as u8);
        } else {
            for k in 1..=s.strategy_images {
                let names = (0..=k).map(|light| format!("s{light}_t{}", k + 1 - light));
                layers.names.extend(names);
            }
        }
        layers.radii = layers.names.len();
        layers
            .names
            .extend((0..s.radii.len()).map(radius_layer_name));
        layers
    }
}

mod memory;
