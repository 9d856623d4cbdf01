//! Checks of algorithm parameters: the error every settings type's `validate` returns,
//! and the checks that several algorithms share (the photon methods' `max_depth`,
//! `light_paths`, radii and alpha), so that each refuses a bad value with the same words.

/// A parameter value that an algorithm refuses: which parameter (`field`, as the
/// settings name it: `radius`, `light_paths.count`) and why (`message`, which names it
/// too, so that it reads alone). The registry names the field as the request wrote it
/// (`params.radius`, or `integrator.radius` for a scene's default).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct ParamError {
    pub field: String,
    pub message: String,
}

impl ParamError {
    pub fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        ParamError {
            field: field.into(),
            message: message.into(),
        }
    }

    /// The error of a shared check applied to a prefixed parameter (`radius` checked
    /// for `medium_radius`): the prefix before both the field and the message.
    pub fn prefixed(self, prefix: &str) -> Self {
        ParamError {
            field: format!("{prefix}{}", self.field),
            message: format!("{prefix}{}", self.message),
        }
    }

    /// The error of a shared check applied to a parameter of another name (`ppb`'s
    /// `max_beam_mib` checked as `max_vertex_mib`).
    pub fn renamed(self, from: &str, to: &str) -> Self {
        ParamError {
            field: self.field.replace(from, to),
            message: self.message.replace(from, to),
        }
    }
}

/// Most photon paths per iteration per pixel (memory stays bounded by waves or by the
/// photon budget; time does not).
pub const MAX_LIGHT_PATHS: f32 = 1024.0;

/// `max_depth`, `light_paths`, `radius` and `radius_factor`.
pub fn check_photon_params(
    max_depth: u32,
    light_paths: f32,
    radius: Option<f32>,
    radius_factor: f32,
) -> Result<(), ParamError> {
    check_max_depth(max_depth)?;
    if !(light_paths > 0.0 && light_paths <= MAX_LIGHT_PATHS) {
        return Err(ParamError::new(
            "light_paths",
            format!("light_paths must be in (0, {MAX_LIGHT_PATHS}]"),
        ));
    }
    check_radius(radius, radius_factor)
}

/// The longest path, which every algorithm but the debug views takes.
pub fn check_max_depth(max_depth: u32) -> Result<(), ParamError> {
    if max_depth == 0 {
        return Err(ParamError::new("max_depth", "max_depth must be at least 1"));
    }
    Ok(())
}

/// A first radius in scene units (optional) and as a fraction of the scene's size.
pub fn check_radius(radius: Option<f32>, radius_factor: f32) -> Result<(), ParamError> {
    if let Some(r) = radius {
        if !(r > 0.0 && r.is_finite()) {
            return Err(ParamError::new(
                "radius",
                format!("radius must be positive and finite, got {r}"),
            ));
        }
    }
    if !(radius_factor > 0.0 && radius_factor.is_finite()) {
        return Err(ParamError::new(
            "radius_factor",
            format!("radius_factor must be positive and finite, got {radius_factor}"),
        ));
    }
    Ok(())
}

/// The radius-reduction exponent alpha of progressive photon mapping.
pub fn check_alpha(alpha: f32) -> Result<(), ParamError> {
    if !(alpha > 0.0 && alpha <= 1.0) {
        return Err(ParamError::new("alpha", "alpha must be in (0, 1]"));
    }
    Ok(())
}
