//! The camera-sample loop shared by pixel-driven integrators: rayon over a fixed list of
//! tiles, one RNG stream per (seed, iteration, pixel), so the image never depends on
//! the thread count.

use crate::film::{tiles, Film, Tile, TileBuffer};
use crate::geometry::Ray;
use crate::integrator::memory::{Estimate, Facts};
use crate::integrator::transport::density_camera::{self, Depths, MediumGather};
use crate::integrator::transport::Stream;
use crate::integrator::{Counters, RenderStats};
use crate::math::{Rgb, Rng, Vec2};
use crate::scene::Scene;
use rayon::prelude::*;

pub const TILE: u32 = 16;

/// Adds what [`render_pixels`] and [`render_paths`] hold to a memory estimate: every
/// tile's buffer, until the tiles are added to the film in their fixed order.
/// With a filter wider than the pixel box each buffer also holds the weights and a
/// border.
pub fn tile_memory(e: &mut Estimate, facts: &Facts) {
    let (scene, filter) = (facts.scene, &facts.scene.filter);
    let bytes = if filter.is_pixel_box() {
        facts.pixels() * TileBuffer::PIXEL_BYTES as f64
    } else {
        let count = scene.width().div_ceil(TILE) as f64 * scene.height().div_ceil(TILE) as f64;
        count * TileBuffer::bytes_for(TILE, filter) as f64
    };
    e.add("camera pass", facts.film(), bytes);
}
/// Camera paths in flight per thread in [`render_paths`]. Three and four measured
/// the same as two (Cornell box `pt`).
const LANES: usize = 2;

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
    render_tiles(
        scene,
        film,
        #[inline(always)]
        |buf| tile_loop(scene, seed, iteration, buf, &radiance),
    )
}

/// The density estimators' camera pass (`vpm`, `ppb`): one camera path per pixel
/// ([`density_camera::li`]), whose medium segments `g` gathers.
pub fn render_density_camera<G: MediumGather + Sync>(
    scene: &Scene,
    (seed, iteration): (u64, u64),
    film: &mut Film,
    g: &G,
    depths: Depths,
) -> RenderStats {
    render_pixels(scene, seed, iteration, film, |ray, rng, st| {
        density_camera::li(scene, g, depths, ray, rng, st)
    })
}

/// Runs `body` over every tile, in parallel, and adds the tiles to `film` in a fixed
/// order.
#[inline(always)]
fn render_tiles<B>(scene: &Scene, film: &mut Film, body: B) -> RenderStats
where
    B: Fn(&mut TileBuffer) -> RenderStats + Sync,
{
    let (w, h) = (scene.width(), scene.height());
    let counters = Counters::default();
    let buffers: Vec<TileBuffer> = tiles(w, h, TILE)
        .into_par_iter()
        .map(|tile| {
            let mut buf = TileBuffer::for_filter(tile, &scene.filter, w, h);
            // A closure, not `&body`: the call through a reference is a function of
            // its own, compiled for baseline x86 outside the AVX2 copy.
            let stats = render_tile(
                &mut buf,
                #[inline(always)]
                |b| body(b),
            );
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
/// they exist. The tile loop `body`, and the integrator's kernel inside it, are inlined
/// into both.
fn render_tile<B>(buf: &mut TileBuffer, body: B) -> RenderStats
where
    B: Fn(&mut TileBuffer) -> RenderStats,
{
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            // SAFETY: the features were detected on this processor just above.
            return unsafe { render_tile_avx2(buf, body) };
        }
    }
    body(buf)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
unsafe fn render_tile_avx2<B>(buf: &mut TileBuffer, body: B) -> RenderStats
where
    B: Fn(&mut TileBuffer) -> RenderStats,
{
    body(buf)
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
    F: Fn(Ray, &mut Rng, &mut RenderStats) -> Rgb + Sync,
{
    let w = scene.width() as u64;
    let tile = buf.tile;
    let mut stats = RenderStats::default();
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            let index = y as u64 * w + x as u64;
            let (ray, mut rng, p) = camera_sample(scene, seed, iteration, index, x, y, &mut stats);
            let v = radiance(ray, &mut rng, &mut stats);
            buf.add_sample(&scene.filter, (x, y, p), v);
        }
    }
    stats
}

/// Pixel (x, y)'s camera sample: its position on the film, uniform in the pixel, and
/// the RNG stream that continues its path.
#[inline(always)]
pub fn film_sample(seed: u64, iteration: u64, index: u64, x: u32, y: u32) -> (Vec2, Rng) {
    let mut rng = Stream::Pixels.rng(seed, iteration, index);
    let film_pos = Vec2::new(x as f32, y as f32) + rng.next_2d();
    (film_pos, rng)
}

/// Pixel (x, y)'s jittered camera ray, the RNG stream that continues its path and the
/// ray's film position.
#[inline(always)]
fn camera_sample(
    scene: &Scene,
    seed: u64,
    iteration: u64,
    index: u64,
    x: u32,
    y: u32,
    stats: &mut RenderStats,
) -> (Ray, Rng, Vec2) {
    let (film_pos, mut rng) = film_sample(seed, iteration, index, x, y);
    let ray = scene.camera.generate_ray(film_pos, rng.next_2d());
    stats.samples += 1;
    stats.rays += 1;
    (ray, rng, film_pos)
}

/// An integrator whose camera paths advance one traced segment at a time, so that
/// [`render_paths`] can keep two paths in flight per thread.
pub trait PathKernel: Sync {
    type Path;
    /// The path of pixel `index` (row-major), starting along a camera ray.
    fn start(&self, index: u64, ray: Ray) -> Self::Path;
    /// Traces the path's next segment and scatters where it lands: the path's
    /// radiance when it has ended.
    fn advance(&self, path: &mut Self::Path, rng: &mut Rng, stats: &mut RenderStats)
        -> Option<Rgb>;
}

/// Like [`render_pixels`], with two camera paths in flight per thread, advanced a
/// segment each in turn. One path is a single chain of dependent work (a hit decides
/// the next ray, whose traversal decides the next hit), and the processor sat idle
/// waiting on it; the segments of two paths are independent, so it overlaps them.
/// Each pixel keeps its own RNG stream, so the image is that of one path at a time.
pub fn render_paths<K: PathKernel>(
    scene: &Scene,
    seed: u64,
    iteration: u64,
    film: &mut Film,
    kernel: &K,
) -> RenderStats {
    render_tiles(
        scene,
        film,
        #[inline(always)]
        |buf| two_path_loop(scene, seed, iteration, buf, kernel),
    )
}

/// The pixels of a tile still to start, in row-major order.
struct Pixels {
    seed: u64,
    iteration: u64,
    tile: Tile,
    /// The film's width.
    w: u64,
    next: u32,
}

impl Pixels {
    /// The camera path of the next pixel, if any is left. Forced inline: a closure
    /// doing this was compiled out of line, for baseline x86 rather than with the tile
    /// loop's AVX2.
    #[inline(always)]
    fn start<K: PathKernel>(
        &mut self,
        scene: &Scene,
        kernel: &K,
        stats: &mut RenderStats,
    ) -> Option<Lane<K::Path>> {
        let t = self.tile;
        if self.next as usize == t.area() {
            return None;
        }
        let (x, y) = (t.x0 + self.next % t.width(), t.y0 + self.next / t.width());
        self.next += 1;
        let index = y as u64 * self.w + x as u64;
        let (ray, rng, p) = camera_sample(scene, self.seed, self.iteration, index, x, y, stats);
        Some(Lane {
            x,
            y,
            p,
            rng,
            path: kernel.start(index, ray),
        })
    }
}

/// A pixel's path in flight.
struct Lane<P> {
    x: u32,
    y: u32,
    /// The camera sample's film position.
    p: Vec2,
    rng: Rng,
    path: P,
}

#[inline(always)]
fn two_path_loop<K: PathKernel>(
    scene: &Scene,
    seed: u64,
    iteration: u64,
    buf: &mut TileBuffer,
    kernel: &K,
) -> RenderStats {
    let mut stats = RenderStats::default();
    let mut pixels = Pixels {
        seed,
        iteration,
        tile: buf.tile,
        w: scene.width() as u64,
        next: 0,
    };
    let mut lanes: [Option<Lane<K::Path>>; LANES] = std::array::from_fn(|_| None);
    for lane in &mut lanes {
        *lane = pixels.start(scene, kernel, &mut stats);
    }
    loop {
        let mut busy = false;
        for lane in &mut lanes {
            let Some(l) = lane else { continue };
            busy = true;
            if let Some(v) = kernel.advance(&mut l.path, &mut l.rng, &mut stats) {
                buf.add_sample(&scene.filter, (l.x, l.y, l.p), v);
                *lane = pixels.start(scene, kernel, &mut stats);
            }
        }
        if !busy {
            return stats;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load::parse_scene;

    /// Paths of pixel-dependent length that draw from their RNG at every segment, so
    /// that a lane mixing up pixels, streams or path ends shows in the image.
    struct Counted;

    struct CountedPath {
        index: u64,
        left: u64,
        draws: u32,
    }

    impl PathKernel for Counted {
        type Path = CountedPath;

        fn start(&self, index: u64, _: Ray) -> CountedPath {
            CountedPath {
                index,
                left: index % 7 + 1,
                draws: 0,
            }
        }

        fn advance(
            &self,
            p: &mut CountedPath,
            rng: &mut Rng,
            stats: &mut RenderStats,
        ) -> Option<Rgb> {
            stats.rays += 1;
            p.draws ^= rng.next_u32() >> 8;
            p.left -= 1;
            (p.left == 0).then(|| Rgb::new(p.index as f32, p.draws as f32, 1.0))
        }
    }

    #[test]
    fn lanes_keep_each_pixel_its_own_path_and_stream() {
        // 37 x 21: full and partial tiles.
        let json = r#"{"format": 1,
            "camera": {"look_at": {"origin": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0]}, "fov": 40},
            "film": {"width": 37, "height": 21}}"#;
        let file = parse_scene(json).expect("scene parses");
        let scene = Scene::compile(&file, None).expect("scene compiles");
        let (w, h) = (37u64, 21u64);
        let (seed, iteration) = (11, 3);
        let mut film = Film::new(w as u32, h as u32);
        let stats = render_paths(&scene, seed, iteration, &mut film, &Counted);
        assert_eq!(stats.samples, w * h);
        let segments: u64 = (0..w * h).map(|i| i % 7 + 1).sum();
        assert_eq!(
            stats.rays,
            w * h + segments,
            "camera rays plus one per segment"
        );
        for (i, sum) in film.sums().iter().enumerate() {
            // One path at a time: the camera sample's four draws, then one per segment.
            let mut rng = Rng::new(seed, iteration, i as u64);
            for _ in 0..4 {
                rng.next_f32();
            }
            let draws = (0..i as u64 % 7 + 1).fold(0, |d, _| d ^ rng.next_u32() >> 8);
            assert_eq!(*sum, [i as f64, draws as f64, 1.0], "pixel {i}");
        }
    }
}
