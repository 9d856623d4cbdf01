//! The one table of algorithms. A row names an algorithm, says in a line what it
//! computes, points to its parameter table and reads its parameters; [`Params`] is what
//! the registry asks of a settings type (check, build, size), and [`Settings::parts`]
//! the one match from a [`Settings`] variant to its row and parameters. `ALGORITHMS`,
//! `Settings::name`, `validate`, `build` and the memory estimate derive from these.
//!
//! Adding an algorithm: its settings type (with `Params`), a variant of `Settings`
//! (the wire format), a row of [`TABLE`] and an arm of `parts`.
//!
//! May import every algorithm module (it is the registry); none of them imports it.

use super::memory::{Estimate, Facts};
use super::photon::{ppb, sppm, vpm};
use super::transport::params::ParamError;
use super::{bidir, debug, many, pt, volpath, Integrator, Settings};
use serde::de::DeserializeOwned;
use serde::Deserialize;
use serde_json::{Map, Value};

/// A parameter that does not parse, with its path under the parameters (`radius`,
/// `light_paths.count`).
pub(crate) type ParseError = serde_path_to_error::Error<serde_json::Error>;

/// One algorithm: a row of [`TABLE`].
pub struct Algorithm {
    /// The name a job gives as `algorithm` (the serde tag of its [`Settings`] variant).
    pub name: &'static str,
    /// What it computes, in one line (the README's Algorithms section says more).
    pub about: &'static str,
    /// The settings type whose doc comment is the parameter table.
    pub params: &'static str,
    /// Its settings from a JSON object of its parameters (no `algorithm` tag).
    parse: fn(Value) -> Result<Settings, ParseError>,
}

/// Every algorithm, in the order that `ALGORITHMS` and `GET /v1/algorithms` list them.
pub const TABLE: &[Algorithm] = &[
    Algorithm {
        name: "pt",
        about: "Unidirectional path tracing with next-event estimation and MIS.",
        params: "pt::PtSettings",
        parse: |p| read(p).map(Settings::Pt),
    },
    Algorithm {
        name: "volpath",
        about: "Volumetric path tracing (what `pt` runs on scenes with media).",
        params: "volpath::VolpathSettings",
        parse: |p| read(p).map(Settings::Volpath),
    },
    Algorithm {
        name: "lt",
        about: "Light tracing: light paths splatted to the camera.",
        params: "bidir::BidirSettings",
        parse: |p| read(p).map(Settings::Lt),
    },
    Algorithm {
        name: "bpt",
        about: "Bidirectional path tracing with all (s, t) connections.",
        params: "bidir::BidirSettings",
        parse: |p| read(p).map(Settings::Bpt),
    },
    Algorithm {
        name: "ppm",
        about: "Progressive photon mapping (visible points fixed per pixel).",
        params: "sppm::SppmSettings",
        parse: |p| read(p).map(Settings::Ppm),
    },
    Algorithm {
        name: "sppm",
        about: "Stochastic progressive photon mapping (new visible points every pass).",
        params: "sppm::SppmSettings",
        parse: |p| read(p).map(Settings::Sppm),
    },
    Algorithm {
        name: "bpm",
        about: "Bidirectional photon mapping: merging at every non-specular camera vertex.",
        params: "bidir::BidirSettings",
        parse: |p| read(p).map(Settings::Bpm),
    },
    Algorithm {
        name: "vcm",
        about: "Vertex connection and merging.",
        params: "bidir::BidirSettings",
        parse: |p| read(p).map(Settings::Vcm),
    },
    Algorithm {
        name: "upbp",
        about: "Unifying points, beams and paths: connections, surface photons and the \
                three volume estimators (any subset) under one MIS.",
        params: "bidir::BidirSettings",
        parse: |p| read(p).map(Settings::Upbp),
    },
    Algorithm {
        name: "vpm",
        about: "Volumetric photon mapping, progressive (point query or beam radiance estimate).",
        params: "vpm::VpmSettings",
        parse: |p| read(p).map(Settings::Vpm),
    },
    Algorithm {
        name: "ppb",
        about: "Progressive photon beams in media; surfaces path traced.",
        params: "ppb::PpbSettings",
        parse: |p| read(p).map(Settings::Ppb),
    },
    Algorithm {
        name: "vpl",
        about: "Virtual point lights, with optional clamping and bias compensation.",
        params: "many::VplSettings",
        parse: |p| read(p).map(Settings::Vpl),
    },
    Algorithm {
        name: "vrl",
        about: "Virtual ray lights in media, virtual point lights on surfaces.",
        params: "many::VrlSettings",
        parse: |p| read(p).map(Settings::Vrl),
    },
    Algorithm {
        name: "vbl",
        about: "Progressive virtual beam lights: ray lights blurred over a shrinking disk.",
        params: "many::VblSettings",
        parse: |p| read(p).map(Settings::Vbl),
    },
    Algorithm {
        name: "normals",
        about: "Debug: shading normal at the first hit, mapped to [0, 1] as (n + 1) / 2.",
        params: "none",
        parse: |p| read(p).map(|NoParams {}| Settings::Normals {}),
    },
    Algorithm {
        name: "albedo",
        about: "Debug: the material's reflectance at the first hit.",
        params: "none",
        parse: |p| read(p).map(|NoParams {}| Settings::Albedo {}),
    },
];

/// The names of [`TABLE`]'s rows, in its order (for the `ALGORITHMS` constant).
pub(super) const fn names<const N: usize>() -> [&'static str; N] {
    let mut out = [""; N];
    let mut i = 0;
    while i < N {
        out[i] = TABLE[i].name;
        i += 1;
    }
    out
}

/// The row of algorithm `name`.
pub fn find(name: &str) -> Option<&'static Algorithm> {
    TABLE.iter().find(|a| a.name == name)
}

impl Algorithm {
    /// Its settings from a JSON object of its parameters; an error names the parameter
    /// that does not parse by its path.
    pub(crate) fn parse(&self, params: Map<String, Value>) -> Result<Settings, ParseError> {
        (self.parse)(Value::Object(params))
    }

    /// Every parameter it takes, at its default value.
    pub(crate) fn defaults(&self) -> serde_json::Result<Map<String, Value>> {
        let settings = self.parse(Map::new()).expect("defaults parse");
        let mut params = match crate::json_numbers::to_value(&settings)? {
            Value::Object(m) => m,
            _ => Map::new(),
        };
        params.remove("algorithm");
        Ok(params)
    }
}

/// A settings type read from JSON in one pass, with the path of what does not parse.
fn read<T: DeserializeOwned>(params: Value) -> Result<T, ParseError> {
    serde_path_to_error::deserialize(params)
}

/// The debug views' parameters: none (so that serde refuses any).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NoParams {}

/// How a job keeps its film, for its memory estimate.
pub(crate) enum FilmUse {
    /// Iterations add samples into it (and splats, for the algorithms that connect
    /// light paths to the camera), with `layers` extra images.
    Adds { splats: bool, layers: usize },
    /// Iterations rewrite it from per-pixel statistics (the photon mappers): the exact
    /// sums are rebuilt each iteration, and they take the pixel box whatever the
    /// scene's filter.
    Chained,
}

/// What the registry asks of an algorithm's settings type. `name` is the algorithm's,
/// for the types that several share (`bidir`'s five, `ppm` and `sppm`).
pub(crate) trait Params {
    fn validate(&self, name: &str) -> Result<(), ParamError>;
    fn build(&self, name: &str) -> Box<dyn Integrator>;
    /// The algorithm's own memory (module `memory`); the film comes on top.
    fn memory(&self, name: &str, facts: &Facts) -> Estimate;
    fn film(&self, _name: &str) -> FilmUse {
        FilmUse::Adds {
            splats: false,
            layers: 0,
        }
    }
}

impl Settings {
    /// The one match over the variants: each one's row name in [`TABLE`] and its
    /// parameters.
    pub(crate) fn parts(&self) -> (&'static str, &dyn Params) {
        match self {
            Settings::Pt(s) => ("pt", s),
            Settings::Volpath(s) => ("volpath", s),
            Settings::Lt(s) => ("lt", s),
            Settings::Bpt(s) => ("bpt", s),
            Settings::Bpm(s) => ("bpm", s),
            Settings::Vcm(s) => ("vcm", s),
            Settings::Upbp(s) => ("upbp", s),
            Settings::Ppm(s) => ("ppm", s),
            Settings::Sppm(s) => ("sppm", s),
            Settings::Vpm(s) => ("vpm", s),
            Settings::Vpl(s) => ("vpl", s),
            Settings::Vrl(s) => ("vrl", s),
            Settings::Vbl(s) => ("vbl", s),
            Settings::Ppb(s) => ("ppb", s),
            Settings::Normals {} => ("normals", &debug::DebugIntegrator::Normals),
            Settings::Albedo {} => ("albedo", &debug::DebugIntegrator::Albedo),
        }
    }
}

/// A settings type of one algorithm: its own `validate` and `memory`, and the
/// integrator's constructor.
macro_rules! one_algorithm {
    ($settings:ty, $new:path) => {
        impl Params for $settings {
            fn validate(&self, _: &str) -> Result<(), ParamError> {
                self.validate()
            }
            fn build(&self, _: &str) -> Box<dyn Integrator> {
                Box::new($new(self.clone()))
            }
            fn memory(&self, _: &str, facts: &Facts) -> Estimate {
                self.memory(facts)
            }
        }
    };
}

one_algorithm!(pt::PtSettings, pt::PathTracer::new);
one_algorithm!(volpath::VolpathSettings, volpath::VolPath::new);
one_algorithm!(vpm::VpmSettings, vpm::Vpm::new);
one_algorithm!(ppb::PpbSettings, ppb::Ppb::new);
one_algorithm!(many::VplSettings, many::ManyLights::vpl);
one_algorithm!(many::VrlSettings, many::ManyLights::vrl);
one_algorithm!(many::VblSettings, many::ManyLights::vbl);

/// `lt`, `bpt`, `bpm`, `vcm` and `upbp`: one core, run as the technique of the name.
impl Params for bidir::BidirSettings {
    fn validate(&self, name: &str) -> Result<(), ParamError> {
        self.validate(self.technique_of(name))
    }
    fn build(&self, name: &str) -> Box<dyn Integrator> {
        Box::new(bidir::Bidir::new(self.technique_of(name), self.clone()))
    }
    fn memory(&self, name: &str, facts: &Facts) -> Estimate {
        self.memory(self.technique_of(name), facts)
    }
    fn film(&self, name: &str) -> FilmUse {
        let technique = self.technique_of(name);
        FilmUse::Adds {
            splats: technique.splats(),
            layers: self.layer_count(technique),
        }
    }
}

/// `ppm` and `sppm`: one photon mapper, with visible points fixed or drawn anew.
impl Params for sppm::SppmSettings {
    fn validate(&self, _: &str) -> Result<(), ParamError> {
        self.validate()
    }
    fn build(&self, name: &str) -> Box<dyn Integrator> {
        let variant = match name {
            "ppm" => sppm::Variant::Ppm,
            _ => sppm::Variant::Sppm,
        };
        Box::new(sppm::PhotonMapper::new(self.clone(), variant))
    }
    fn memory(&self, _: &str, facts: &Facts) -> Estimate {
        self.memory(facts)
    }
    fn film(&self, _: &str) -> FilmUse {
        FilmUse::Chained
    }
}

/// The debug views take no parameters.
impl Params for debug::DebugIntegrator {
    fn validate(&self, _: &str) -> Result<(), ParamError> {
        Ok(())
    }
    fn build(&self, _: &str) -> Box<dyn Integrator> {
        Box::new(match self {
            debug::DebugIntegrator::Normals => debug::DebugIntegrator::Normals,
            debug::DebugIntegrator::Albedo => debug::DebugIntegrator::Albedo,
        })
    }
    fn memory(&self, _: &str, facts: &Facts) -> Estimate {
        debug::DebugIntegrator::memory(facts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::{SettingsError, ALGORITHMS};
    use serde_json::json;

    fn map(v: Value) -> Map<String, Value> {
        v.as_object().expect("an object").clone()
    }

    /// Each row reads its own variant: its defaults parse to settings of its name,
    /// which serialise with that tag and validate.
    #[test]
    fn every_row_reads_its_own_variant() {
        assert_eq!(ALGORITHMS.len(), TABLE.len());
        for (row, name) in TABLE.iter().zip(ALGORITHMS) {
            assert_eq!(row.name, *name);
            let s = row.parse(Map::new()).unwrap();
            assert_eq!(s.name(), row.name);
            assert_eq!(serde_json::to_value(&s).unwrap()["algorithm"], row.name);
            s.validate().unwrap();
            assert!(find(row.name).is_some_and(|r| std::ptr::eq(r, row)));
        }
    }

    /// One bad parameter of every algorithm: the error names it as the job wrote it
    /// (`field`), with the message it had when it was only text.
    #[test]
    fn a_bad_parameter_of_every_algorithm_is_named() {
        #[rustfmt::skip]
        let cases = [
            ("pt", json!({"max_depth": 0}), "params.max_depth", "integrator settings: max_depth must be at least 1"),
            ("volpath", json!({"max_depth": "deep"}), "params.max_depth", "params.max_depth: invalid type: string \"deep\""),
            ("lt", json!({"light_paths": 100}), "params.light_paths", "light_paths must be in (0, 64], got 100"),
            ("bpt", json!({"radius": -1}), "params.radius", "radius must be positive and finite, got -1"),
            ("ppm", json!({"alpha": 2}), "params.alpha", "alpha must be in (0, 1]"),
            ("sppm", json!({"medium_radius_factor": 0}), "params.medium_radius_factor", "medium_radius_factor must be positive"),
            ("bpm", json!({"merge_first": false}), "params.merge_first", "merge_first: false leaves bpm"),
            ("vcm", json!({"pb2d_alpha": 0}), "params.pb2d_alpha", "pb2d_alpha must be in (0, 1], got 0"),
            ("upbp", json!({"techniques": ["surf", "surf"]}), "params.techniques", "techniques names surf twice"),
            ("vpm", json!({"max_photon_mib": 0}), "params.max_photon_mib", "max_photon_mib must be at least 1"),
            ("ppb", json!({"max_beam_mib": 0}), "params.max_beam_mib", "max_beam_mib must be positive, got 0"),
            ("vpl", json!({"clamp_limit": 2}), "params.clamp_limit", "clamp_limit needs clamp"),
            ("vrl", json!({"light_paths": {"count": 0}}), "params.light_paths.count", "light_paths.count must be in 1..="),
            ("vbl", json!({"vl_samples": 5000}), "params.vl_samples", "vl_samples must be at most 4096"),
            ("normals", json!({"max_depth": 3}), "params.max_depth", "params.max_depth: unknown field `max_depth`"),
            ("albedo", json!({"exposure": 1}), "params.exposure", "params.exposure: unknown field `exposure`"),
        ];
        let covered: Vec<_> = cases.iter().map(|c| c.0).collect();
        assert_eq!(covered, ALGORITHMS.to_vec());
        for (alg, params, field, words) in cases {
            let e = Settings::resolve(Some(alg), None, &map(params)).unwrap_err();
            assert_eq!(e.field(), Some(field), "{alg}: {e}");
            assert!(e.to_string().contains(words), "{alg}: {e}");
        }
    }

    /// `selection: adaptive` where it cannot apply, or a value it does not know, is
    /// refused naming the field.
    #[test]
    fn a_bad_selection_is_named() {
        let cases = [
            (
                "bpt",
                json!({"selection": "adaptive"}),
                "chooses merge estimators: it needs bpm",
            ),
            (
                "vcm",
                json!({"selection": "adaptive", "radii": [0.01]}),
                "renders no radius layers",
            ),
            (
                "upbp",
                json!({"selection": "sometimes"}),
                "unknown variant `sometimes`",
            ),
        ];
        for (alg, params, words) in cases {
            let e = Settings::resolve(Some(alg), None, &map(params)).unwrap_err();
            assert_eq!(e.field(), Some("params.selection"), "{alg}: {e}");
            assert!(e.to_string().contains(words), "{alg}: {e}");
        }
        let fine = map(json!({"selection": "adaptive"}));
        Settings::resolve(Some("upbp"), None, &fine).unwrap();
    }

    /// `selection: auto` (the default) is adaptive for plain `upbp` only; an explicit
    /// choice stands.
    #[test]
    fn the_default_selection_is_adaptive_for_upbp_alone() {
        use bidir::PixelSelection::{Adaptive, All};
        let resolved = |alg: &str, params: Value| {
            let (Settings::Bpm(s) | Settings::Vcm(s) | Settings::Upbp(s)) =
                Settings::resolve(Some(alg), None, &map(params)).unwrap()
            else {
                panic!("{alg} is not a merging algorithm");
            };
            s.selection_for(s.technique_of(alg))
        };
        assert_eq!(resolved("upbp", json!({})), Adaptive);
        assert_eq!(resolved("upbp", json!({"selection": "all"})), All);
        assert_eq!(resolved("upbp", json!({"radii": [0.01, 0.02]})), All);
        let correlated = json!({"correlation_aware": true, "merge_depth": "all"});
        assert_eq!(resolved("upbp", correlated), All);
        // Connections alone: nothing to select.
        assert_eq!(resolved("upbp", json!({"techniques": "bpt"})), All);
        assert_eq!(resolved("vcm", json!({})), All);
        assert_eq!(resolved("bpm", json!({})), All);
        assert_eq!(resolved("vcm", json!({"selection": "adaptive"})), Adaptive);
    }

    #[test]
    fn correlation_aware_is_refused_where_its_evaluator_does_not_reach() {
        let on = |extra: serde_json::Value| {
            let mut p = json!({"correlation_aware": true, "merge_depth": "all"});
            for (k, v) in extra.as_object().unwrap() {
                p[k] = v.clone();
            }
            p
        };
        let cases = [
            ("bpt", on(json!({})), "needs bpm, vcm or upbp"),
            (
                "vcm",
                json!({"correlation_aware": true}),
                "set merge_depth: all",
            ),
            (
                "vcm",
                on(json!({"radii": [0.01]})),
                "not combined with radii",
            ),
            (
                "bpm",
                on(json!({"selection": "adaptive"})),
                "selection: adaptive",
            ),
        ];
        for (alg, params, words) in cases {
            let e = Settings::resolve(Some(alg), None, &map(params)).unwrap_err();
            assert_eq!(e.field(), Some("params.correlation_aware"), "{alg}: {e}");
            assert!(e.to_string().contains(words), "{alg}: {e}");
        }
        // Every upbp estimator, beams included.
        let fine = on(json!({"techniques": "bpt+surf+pp3d+pb2d+bb1d"}));
        Settings::resolve(Some("upbp"), None, &map(fine)).unwrap();
        Settings::resolve(Some("vcm"), None, &map(on(json!({})))).unwrap();
    }

    /// A bad parameter that a scene's defaults gave is named where the scene says it
    /// (`integrator.<name>`); a job's own, as the job wrote it.
    #[test]
    fn a_scene_default_is_named_in_the_scene() {
        let none = Map::new();
        let scene = json!({"algorithm": "vcm", "radius": -1.0});
        let e = Settings::resolve(None, Some(&scene), &none).unwrap_err();
        assert_eq!(e.field(), Some("integrator.radius"), "{e}");
        let fixed = map(json!({"radius": 0.5}));
        Settings::resolve(None, Some(&scene), &fixed).unwrap();
        let worse = map(json!({"radius": -2.0}));
        let e = Settings::resolve(None, Some(&scene), &worse).unwrap_err();
        assert_eq!(e.field(), Some("params.radius"), "{e}");

        let scene = json!({"algorithm": "vcm", "radius": "big"});
        let e = Settings::resolve(None, Some(&scene), &none).unwrap_err();
        assert_eq!(e.field(), Some("integrator.radius"), "{e}");
        assert!(
            e.to_string().contains("integrator.radius: invalid type"),
            "{e}"
        );

        let section = json!({"algorithm": "vpl", "clamp_limit": 1.0});
        let e = Settings::scene_defaults(Some(&section)).unwrap_err();
        assert_eq!(e.field(), Some("integrator.clamp_limit"), "{e}");
        let section = json!({"algorithm": "vpl", "light_paths": {"count": "many"}});
        let e = Settings::scene_defaults(Some(&section)).unwrap_err();
        assert_eq!(e.field(), Some("integrator.light_paths"), "{e}");
        assert!(e.to_string().contains("integrator.light_paths: "), "{e}");

        let e = Settings::resolve(Some("pt"), None, &map(json!({"algorithm": "vcm"})));
        assert_eq!(e.unwrap_err().field(), Some("params.algorithm"));
        let e = Settings::resolve(Some("pt2"), None, &none).unwrap_err();
        assert!(matches!(e, SettingsError::UnknownAlgorithm(_)) && e.field().is_none());
    }

    /// A scene default's `max_depth` carries over to every algorithm that takes one,
    /// and to no other.
    #[test]
    fn a_shared_default_reaches_the_algorithms_that_take_it() {
        let scene = json!({"algorithm": "pt", "max_depth": 7, "roulette": "albedo"});
        let none = Map::new();
        for alg in ALGORITHMS {
            let s = Settings::resolve(Some(alg), Some(&scene), &none)
                .unwrap_or_else(|e| panic!("{alg}: {e}"));
            let depth = crate::json_numbers::to_value(&s).unwrap()["max_depth"].clone();
            let want = match *alg {
                "normals" | "albedo" => Value::Null,
                _ => json!(7),
            };
            assert_eq!(depth, want, "{alg}");
        }
    }
}
