//! `<integrator>` and `<sampler>`: how to render, not what the scene is. So nothing
//! here blocks an import: an integrator caustic lacks becomes its nearest algorithm,
//! a sampler becomes caustic's independent random numbers, and an option that does not
//! carry over (or does not parse) falls back to the default; each such choice is a
//! warning that names it. Options that change only the noise or the speed (sample
//! counts per technique, pass sizes, seeds) are dropped without a word.

use super::node::Node;
use super::params::Params;
use super::Ctx;
use crate::scene::error::Result;

/// What Mitsuba's `max_depth` -1 (no limit) becomes.
pub const UNLIMITED_DEPTH: u32 = 1024;

/// Options of Mitsuba's integrators (0.x and 3) that change the noise or the running
/// time, never the expected image.
const NOISE_ONLY: &[&str] = &[
    "samples_per_pass",
    "timeout",
    "block_size",
    "granularity",
    "shading_samples",
    "emitter_samples",
    "bsdf_samples",
    "direct_samples",
    "glossy_samples",
    "luminance_samples",
    "light_image",
    "sample_direct",
    "brute_force",
    "use_spectral_mis",
    "two_stage",
    "p_large",
    "lambda",
    "num_chains",
    "max_chains",
    "chain_length",
    "max_passes",
    "photon_count",
    "initial_radius",
    "alpha",
];

/// What Mitsuba 0.x's photon mapper sets that `sppm` chooses for itself.
const PHOTON_MAPPER: &[&str] = &[
    "global_photons",
    "caustic_photons",
    "volume_photons",
    "global_lookup_radius",
    "caustic_lookup_radius",
    "lookup_size",
];

/// Wrappers inside wrappers deeper than this (only a loop of references gets there)
/// end in the default algorithm.
const MAX_NESTING: usize = 8;

/// Integrators that wrap others (adaptive sampling, caches, extra outputs): caustic
/// renders the wrapped one, and what the wrapper adds is named in the warning.
const WRAPPERS: &[(&str, &str)] = &[
    (
        "adaptive",
        "its adaptive sample counts (the same expected image)",
    ),
    (
        "irrcache",
        "its irradiance cache (an interpolated, biased image)",
    ),
    ("multichannel", "its other channels"),
    ("aov", "its arbitrary output variables"),
    ("moment", "its moment outputs"),
    ("stokes", "its polarisation outputs"),
];

/// The caustic algorithm for a Mitsuba integrator that is not a wrapper, and why it
/// is only the nearest one (`None`: the same expected image).
fn algorithm(kind: &str, p: &Params, ctx: &mut Ctx) -> (&'static str, Option<String>) {
    let same_image = |alg: &str, what: &str| {
        Some(format!(
            "caustic has no {what}: rendered with {alg}, the same expected image with \
             different noise"
        ))
    };
    match kind {
        "path" => ("pt", None),
        "volpath" | "volpathmis" => ("volpath", None),
        "bdpt" => ("bpt", None),
        "ptracer" => ("lt", None),
        "ppm" => ("ppm", None),
        "sppm" => ("sppm", None),
        "vpl" => (
            "vpl",
            Some(
                "Mitsuba's vpl clamps each virtual light's contribution (clamping, 0.1 by \
                 default), which darkens corners; caustic's vpl renders without clamping \
                 (its default, unbiased)"
                    .into(),
            ),
        ),
        "volpath_simple" => ("volpath", same_image("volpath", "volpath_simple")),
        "direct" | "direct_projective" => (
            "pt",
            Some(format!(
                "{kind} (emitters and direct lighting only) becomes pt with max_depth 2"
            )),
        ),
        "photonmapper" => (
            "sppm",
            Some(
                "caustic has no photon mapper with final gathering: rendered with sppm, \
                 which converges to the image without the photon map's bias (its photon \
                 counts and lookup radii do not carry over)"
                    .into(),
            ),
        ),
        "pssmlt" if lenient(ctx, p.boolean("bidirectional")) == Some(false) => {
            ("pt", same_image("pt", "Metropolis sampling"))
        }
        "pssmlt" | "mlt" => ("bpt", same_image("bpt", "Metropolis sampling")),
        "erpt" => ("pt", same_image("pt", "energy redistribution")),
        "prb" | "prb_basic" | "prb_projective" => ("pt", same_image("pt", kind)),
        "prbvolpath" => ("volpath", same_image("volpath", kind)),
        other => (
            "pt",
            Some(format!(
                "\"{other}\" is not an integrator caustic has (or not one that renders \
                 light transport): rendered with pt, Mitsuba's default path tracer"
            )),
        ),
    }
}

/// What a scene without an `<integrator>` renders with: Mitsuba 3's default, a path
/// tracer without a depth limit; Mitsuba 0.x's, direct illumination (its `direct`).
pub fn default(root: &Node, ctx: &mut Ctx) -> serde_json::Value {
    let (depth, what) = if root.legacy() {
        (2, "Mitsuba 0.x's default, direct illumination,")
    } else {
        (
            UNLIMITED_DEPTH,
            "Mitsuba's default path tracer with unlimited max_depth",
        )
    };
    ctx.warnings.push(format!(
        "{}: no <integrator>: {what} becomes pt with max_depth {depth}",
        root.loc
    ));
    serde_json::json!({"algorithm": "pt", "max_depth": depth})
}

/// `{"algorithm": ..., "max_depth": ...}` for the scene's `integrator`; `pixels` is the
/// film's pixel count (photon counts per pass become caustic's per-pixel ones).
pub fn integrator<'a>(n: &'a Node, ctx: &mut Ctx<'a>, pixels: u64) -> Result<serde_json::Value> {
    convert(n, ctx, pixels, 0)
}

fn convert<'a>(
    n: &'a Node,
    ctx: &mut Ctx<'a>,
    pixels: u64,
    nesting: usize,
) -> Result<serde_json::Value> {
    let p = Params::new(n, ctx)?;
    if let Some((_, what)) = WRAPPERS.iter().find(|(k, _)| *k == n.kind()) {
        let inner = p.object(&["integrator"], None)?;
        if let Some(inner) = inner.filter(|_| nesting < MAX_NESTING) {
            ctx.warn(
                n,
                format!(
                    "caustic renders the integrator it wraps, {}, without {what}",
                    inner.label()
                ),
            );
            return convert(inner, ctx, pixels, nesting + 1);
        }
    }
    let (algorithm, note) = algorithm(n.kind(), &p, ctx);
    if let Some(note) = note {
        ctx.warn(n, note);
    }
    let mut out = serde_json::json!({ "algorithm": algorithm });
    out["max_depth"] = match n.kind() {
        "direct" | "direct_projective" => 2.into(),
        _ => max_depth(n, &p, ctx).into(),
    };
    if let Some(rr) = lenient(ctx, p.int("rr_depth")) {
        match (u32::try_from(rr), algorithm) {
            (Err(_), _) => ctx.warn(n, format!("rr_depth {rr} is negative; ignored")),
            (Ok(rr), "pt" | "volpath" | "ppm" | "sppm") => out["rr_depth"] = rr.into(),
            _ => ctx.warn(
                n,
                format!(
                    "rr_depth is ignored: caustic's {algorithm} plays Russian roulette on the \
                     albedo at every vertex (the same expected image)"
                ),
            ),
        }
    }
    if algorithm == "ppm" || algorithm == "sppm" {
        photon_settings(n, &p, ctx, pixels, &mut out);
    }
    if lenient(ctx, p.boolean("hide_emitters")) == Some(true) {
        ctx.warn(
            n,
            "hide_emitters is ignored: caustic shows the emitters the camera sees directly \
             (and the environment behind the scene)",
        );
    }
    if lenient(ctx, p.boolean("strict_normals")) == Some(true) {
        ctx.warn(
            n,
            "strict_normals is ignored: caustic keeps paths whose shading and geometric \
             normals disagree (a difference only on meshes with interpolated normals)",
        );
    }
    p.ignore(NOISE_ONLY);
    p.ignore(&["bidirectional", "clamping", "shadow_map_resolution"]);
    p.ignore(PHOTON_MAPPER);
    warn_unread(&p, ctx, "the integrator");
    Ok(out)
}

/// Mitsuba's `max_depth` (-1: no limit) as caustic's, which must be at least 1.
fn max_depth(n: &Node, p: &Params, ctx: &mut Ctx) -> u32 {
    match lenient(ctx, p.int("max_depth")).unwrap_or(-1) {
        d if d >= 1 => u32::try_from(d).unwrap_or(UNLIMITED_DEPTH),
        -1 => {
            ctx.warn(
                n,
                format!("max_depth -1 (no limit) becomes {UNLIMITED_DEPTH}"),
            );
            UNLIMITED_DEPTH
        }
        0 => {
            ctx.warn(
                n,
                "max_depth 0 (an empty image in Mitsuba) becomes 1, the emitters the \
                 camera sees",
            );
            1
        }
        d => {
            ctx.warn(
                n,
                format!("max_depth {d} is not -1 or a depth; no limit ({UNLIMITED_DEPTH}) used"),
            );
            UNLIMITED_DEPTH
        }
    }
}

/// Mitsuba 0.x's `ppm` and `sppm` options as caustic's: `photon_count` photons a pass
/// becomes `light_paths` per pixel, `initial_radius` (0: automatic) the first radius.
fn photon_settings(n: &Node, p: &Params, ctx: &mut Ctx, pixels: u64, out: &mut serde_json::Value) {
    if let Some(count) = lenient(ctx, p.int("photon_count")).filter(|&c| c > 0) {
        out["light_paths"] = (count as f64 / pixels.max(1) as f64).into();
    }
    if let Some(r) = lenient(ctx, p.float("initial_radius")).filter(|&r| r > 0.0) {
        out["radius"] = r.into();
    }
    match lenient(ctx, p.float("alpha")) {
        Some(a) if a > 0.0 && a <= 1.0 => out["alpha"] = a.into(),
        Some(a) => ctx.warn(
            n,
            format!("alpha {a} is not in (0, 1]; caustic's default used"),
        ),
        None => {}
    }
}

/// A render setting that does not parse is a warning and Mitsuba's default.
fn lenient<T>(ctx: &mut Ctx, value: Result<Option<T>>) -> Option<T> {
    value.unwrap_or_else(|e| {
        ctx.warnings
            .push(format!("{e}; ignored, the default is used"));
        None
    })
}

/// One warning naming the options of `p` that nothing read.
fn warn_unread(p: &Params, ctx: &mut Ctx, what: &str) {
    let unread: Vec<String> = p.unread().iter().map(|c| c.label()).collect();
    if !unread.is_empty() {
        ctx.warn(
            p.node,
            format!(
                "{what} in caustic has no equivalent of {}; ignored",
                unread.join(", ")
            ),
        );
    }
}

/// The sampler's `sample_count`, the render's default length. Every sampler becomes
/// caustic's independent random numbers: the same expected image.
pub fn sampler<'a>(p: &Params<'a>, ctx: &mut Ctx<'a>) -> Result<Option<u32>> {
    let Some(n) = p.object(&["sampler"], None)? else {
        return Ok(None);
    };
    let s = Params::new(n, ctx)?;
    let spp = match lenient(ctx, s.int("sample_count")).unwrap_or(4) {
        c if c >= 1 => u32::try_from(c).unwrap_or(u32::MAX),
        c => {
            ctx.warn(
                n,
                format!("sample_count {c} is not a sample count; Mitsuba's default 4 used"),
            );
            4
        }
    };
    // Seeds and stratification change the noise, not the expected image.
    s.ignore(&[
        "seed",
        "jitter",
        "scramble_seed",
        "scramble",
        "dimension",
        "strength",
    ]);
    match n.kind() {
        "independent" => {}
        "stratified" | "multijitter" | "orthogonal" | "ldsampler" | "halton" | "hammersley"
        | "sobol" | "pmj02" => ctx.warn(
            n,
            "caustic samples with independent random numbers: the same expected image \
             with different noise",
        ),
        other => ctx.warn(
            n,
            format!(
                "unknown sampler plugin \"{other}\": caustic samples with independent \
                 random numbers (the same expected image)"
            ),
        ),
    }
    warn_unread(&s, ctx, "the sampler");
    Ok(Some(spp))
}
