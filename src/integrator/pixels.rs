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
    let (w, h) = (scene.width(), scene.height());
    let counters = Counters::default();
    let buffers: Vec<TileBuffer> = tiles(w, h, TILE)
        .into_par_iter()
        .map(|tile| {
            let mut buf = TileBuffer::new(tile);
            let mut stats = RenderStats::default();
            for y in tile.y0..tile.y1 {
                for x in tile.x0..tile.x1 {
                    let index = y as u64 * w as u64 + x as u64;
                    let mut rng = Rng::new(seed, iteration, index);
                    let film_pos = Vec2::new(x as f32, y as f32) + rng.next_2d();
                    let ray = scene.camera.generate_ray(film_pos, rng.next_2d());
                    stats.samples += 1;
                    stats.rays += 1;
                    buf.add(x, y, radiance(ray, &mut rng, &mut stats));
                }
            }
            counters.add(&stats);
            buf
        })
        .collect();
    for b in &buffers {
        film.add_tile_buffer(b);
    }
    counters.get()
}
