//! The camera-sample loop shared by pixel-driven integrators: rayon over a fixed list of
//! tiles, one RNG stream per (seed, iteration, pixel), so the image never depends on
//! the thread count.

use super::{Counters, RenderStats};
use crate::film::{tiles, Film, TileBuffer};
use crate::geometry::Ray;
use crate::math::{Rgb, Rng, Vec2};
use crate::scene::Scene;
use rayon::prelude::*;

pub const TILE: u32 = 16;

/// Calls `radiance(ray, rng, stats)` for one jittered camera ray per pixel and adds the
/// results to `film`.
pub fn render_pixels<F>(
    scene: &Scene,
    seed: u64,
    iteration: u64,
    film: &mut Film,
    radiance: F,
) -> RenderStats
where
    F: Fn(Ray, &mut Rng, &mut RenderStats) -> Rgb + Sync,
{
    // Inlined like the kernel itself: without it this wrapper is a function of its own,
    // compiled for the baseline target and called per pixel, and the kernel inside it
    // never gets the AVX2 copy of the tile loop.
    render_pixels_indexed(
        scene,
        seed,
        iteration,
        film,
        #[inline(always)]
        |_, ray, rng, stats| radiance(ray, rng, stats),
    )
}

/// Like [`render_pixels`], also passing the row-major pixel index (bidirectional
/// methods pair each camera path with the light path of the same index).
pub fn render_pixels_indexed<F>(
    scene: &Scene,
    seed: u64,
    iteration: u64,
    film: &mut Film,
    radiance: F,
) -> RenderStats
where
    F: Fn(u64, Ray, &mut Rng, &mut RenderStats) -> Rgb + Sync,
{
    let (w, h) = (scene.width(), scene.height());
    let counters = Counters::default();
    let buffers: Vec<TileBuffer> = tiles(w, h, TILE)
        .into_par_iter()
        .map(|tile| {
            let mut buf = TileBuffer::new(tile);
            let stats = render_tile(scene, seed, iteration, &mut buf, &radiance);
            counters.add(&stats);
            buf
        })
        .collect();
    for b in &buffers {
        film.add_tile_buffer(b);
    }
    counters.get()
}

/// One tile, compiled twice: for AVX2 + FMA processors (chosen at run time) and for
/// baseline x86-64, so one binary runs everywhere and uses wide instructions where
/// they exist. The integrator's kernel is inlined into both.
fn render_tile<F>(
    scene: &Scene,
    seed: u64,
    iteration: u64,
    buf: &mut TileBuffer,
    radiance: &F,
) -> RenderStats
where
    F: Fn(u64, Ray, &mut Rng, &mut RenderStats) -> Rgb + Sync,
{
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            // SAFETY: the features were detected on this processor just above.
            return unsafe { render_tile_avx2(scene, seed, iteration, buf, radiance) };
        }
    }
    tile_loop(scene, seed, iteration, buf, radiance)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
unsafe fn render_tile_avx2<F>(
    scene: &Scene,
    seed: u64,
    iteration: u64,
    buf: &mut TileBuffer,
    radiance: &F,
) -> RenderStats
where
    F: Fn(u64, Ray, &mut Rng, &mut RenderStats) -> Rgb + Sync,
{
    tile_loop(scene, seed, iteration, buf, radiance)
}

#[inline(always)]
fn tile_loop<F>(
    scene: &Scene,
    seed: u64,
    iteration: u64,
    buf: &mut TileBuffer,
    radiance: &F,
) -> RenderStats
where
    F: Fn(u64, Ray, &mut Rng, &mut RenderStats) -> Rgb + Sync,
{
    let w = scene.width() as u64;
    let tile = buf.tile;
    let mut stats = RenderStats::default();
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            let index = y as u64 * w + x as u64;
            let mut rng = Rng::new(seed, iteration, index);
            let film_pos = Vec2::new(x as f32, y as f32) + rng.next_2d();
            let ray = scene.camera.generate_ray(film_pos, rng.next_2d());
            stats.samples += 1;
            stats.rays += 1;
            buf.add(x, y, radiance(index, ray, &mut rng, &mut stats));
        }
    }
    stats
}
