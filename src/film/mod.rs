//! Film: per-pixel accumulation of radiance samples through a pixel filter, linear
//! images, EXR and PNG input/output, and error metrics against a reference.
//!
//! Everything here is linear RGB (`glam::Vec3`) with image row 0 at the top, as the
//! design notes require. The module depends on no other caustic module.

mod accum;
mod atomic;
mod error;
mod exact;
mod exr_io;
mod filter;
mod hdr_io;
mod image;
mod metrics;
mod noise;
mod png_io;
mod sample;
mod sniff;
mod tile;

pub use accum::{Film, Layer};
pub use atomic::write_bytes_atomic;
pub use error::{FilmError, MAX_PIXELS};
pub use exact::{ExactError, ExactSums};
pub use exr_io::{
    decode_exr, decode_exr_layer, encode_exr, encode_exr_layers, read_exr, read_exr_layer,
    read_exr_named, write_exr, write_exr_layers,
};
pub use filter::{Filter, PixelFilter, Taps, MAX_RADIUS};
pub use hdr_io::{decode_hdr, read_hdr, read_image};
pub use image::Image;
pub use metrics::{compare, false_colour_diff, rel_mse, rmse, ErrorMetrics};
pub use noise::{Noise, MIN_ITERATIONS as NOISE_MIN_ITERATIONS};
pub use png_io::{encode_png, srgb_eotf, srgb_oetf, to_srgb8, write_png};
pub use sample::is_valid_sample;
pub use sniff::{is_exr, not_exr, other_image_format};
pub use tile::{tiles, Tile, TileBuffer};
