//! Checks of the parameters that the photon methods (sppm, ppm, vpm) share, so that
//! each refuses a bad value with the same words.

/// Most photon paths per iteration per pixel (memory stays bounded by waves or by the
/// photon budget; time does not).
pub const MAX_LIGHT_PATHS: f32 = 1024.0;

/// `max_depth`, `light_paths`, `radius` and `radius_factor`.
pub fn check_photon_params(
    max_depth: u32,
    light_paths: f32,
    radius: Option<f32>,
    radius_factor: f32,
) -> Result<(), String> {
    if max_depth == 0 {
        return Err("max_depth must be at least 1".into());
    }
    if !(light_paths > 0.0 && light_paths <= MAX_LIGHT_PATHS) {
        return Err(format!("light_paths must be in (0, {MAX_LIGHT_PATHS}]"));
    }
    check_radius(radius, radius_factor)
}

/// A first radius in scene units (optional) and as a fraction of the scene's size.
pub fn check_radius(radius: Option<f32>, radius_factor: f32) -> Result<(), String> {
    if let Some(r) = radius {
        if !(r > 0.0 && r.is_finite()) {
            return Err(format!("radius must be positive and finite, got {r}"));
        }
    }
    if !(radius_factor > 0.0 && radius_factor.is_finite()) {
        return Err(format!(
            "radius_factor must be positive and finite, got {radius_factor}"
        ));
    }
    Ok(())
}

/// The radius-reduction exponent alpha of progressive photon mapping.
pub fn check_alpha(alpha: f32) -> Result<(), String> {
    if !(alpha > 0.0 && alpha <= 1.0) {
        return Err("alpha must be in (0, 1]".into());
    }
    Ok(())
}
