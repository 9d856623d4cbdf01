use glam::Vec3 as Rgb;

use super::image::{pixel_count, Image};

/// Whether a sample may enter the film. NaN, infinite or negative radiance is a
/// bug upstream; averaging it in would hide the bug, so it is dropped and counted.
pub fn is_valid_sample(v: Rgb) -> bool {
    v.is_finite() && v.cmpge(Rgb::ZERO).all()
}

/// Per-pixel sums of radiance samples, in f64 so that thousands of iterations can
/// be summed without the later ones vanishing in rounding.
#[derive(Debug, Clone, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    sums: Vec<[f64; 3]>,
    dropped: u64,
    layers: Vec<Layer>,
}

/// An extra image an integrator splits its estimate into (e.g. the contributions of
/// one technique). It counts its own iterations, so a layer that starts later (after a
/// restart from a checkpoint, which keeps only the main sums) still averages right.
#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    pub name: String,
    pub iterations: u64,
    sums: Vec<[f64; 3]>,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            sums: vec![[0.0; 3]; pixel_count(width, height)],
            dropped: 0,
            layers: Vec::new(),
        }
    }

    /// Rebuilds a film from saved state (e.g. a checkpoint). Panics if `sums` does
    /// not hold `width * height` pixels.
    pub fn from_parts(width: u32, height: u32, sums: Vec<[f64; 3]>, dropped: u64) -> Self {
        assert_eq!(
            sums.len(),
            pixel_count(width, height),
            "Film::from_parts: {} sums given for a {width}x{height} film",
            sums.len()
        );
        Self {
            width,
            height,
            sums,
            dropped,
            layers: Vec::new(),
        }
    }

    /// Bytes the sums of a `width` x `height` film with `layers` layers hold (what a
    /// job's memory estimate counts for it).
    pub fn bytes_for(width: u32, height: u32, layers: usize) -> u64 {
        let per_image = pixel_count(width, height) * std::mem::size_of::<[f64; 3]>();
        (per_image * (1 + layers)) as u64
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    pub fn sums(&self) -> &[[f64; 3]] {
        &self.sums
    }

    pub fn sums_mut(&mut self) -> &mut [[f64; 3]] {
        &mut self.sums
    }

    /// Number of samples rejected by [`is_valid_sample`] since the last `clear`.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Adds a sample to pixel (x, y), or counts it as dropped if it is invalid.
    pub fn add(&mut self, x: u32, y: u32, v: Rgb) {
        // Checked here because y * width + x would silently wrap into the next row.
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside a {}x{} film",
            self.width,
            self.height
        );
        self.add_index(y as usize * self.width as usize + x as usize, v);
    }

    /// Like [`Film::add`], by row-major pixel index.
    pub fn add_index(&mut self, i: usize, v: Rgb) {
        accumulate(&mut self.sums[i], &mut self.dropped, v);
    }

    /// Adds another film of the same size (e.g. one worker's iterations).
    pub fn merge(&mut self, other: &Film) {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "Film::merge: films of different sizes"
        );
        for (s, o) in self.sums.iter_mut().zip(&other.sums) {
            add3(s, o);
        }
        self.dropped += other.dropped;
        for l in &other.layers {
            let k = self.begin_layer(&l.name);
            let mine = &mut self.layers[k];
            mine.iterations += l.iterations - 1;
            for (s, o) in mine.sums.iter_mut().zip(&l.sums) {
                add3(s, o);
            }
        }
    }

    /// Index of layer `name` (created empty on first use), counting one more
    /// iteration for it: call once per iteration that adds to the layer.
    pub fn begin_layer(&mut self, name: &str) -> usize {
        let n = pixel_count(self.width, self.height);
        let k = match self.layers.iter().position(|l| l.name == name) {
            Some(k) => k,
            None => {
                self.layers.push(Layer {
                    name: name.to_string(),
                    iterations: 0,
                    sums: vec![[0.0; 3]; n],
                });
                self.layers.len() - 1
            }
        };
        self.layers[k].iterations += 1;
        k
    }

    /// Adds to a layer; invalid values are skipped (the main image counts them).
    pub fn add_layer_index(&mut self, layer: usize, i: usize, v: Rgb) {
        if is_valid_sample(v) {
            add3(
                &mut self.layers[layer].sums[i],
                &[v.x as f64, v.y as f64, v.z as f64],
            );
        }
    }

    /// Each layer's name, iteration count and sums.
    pub fn layer_sums(&self) -> impl Iterator<Item = (&str, u64, &[[f64; 3]])> {
        self.layers
            .iter()
            .map(|l| (l.name.as_str(), l.iterations, l.sums.as_slice()))
    }

    /// Adds a whole layer (e.g. from saved sums). Panics if `sums` does not hold one
    /// value per pixel.
    pub fn push_layer(&mut self, name: &str, iterations: u64, sums: Vec<[f64; 3]>) {
        assert_eq!(sums.len(), self.sums.len(), "Film::push_layer: wrong size");
        self.layers.push(Layer {
            name: name.to_string(),
            iterations,
            sums,
        });
    }

    /// Each layer's mean image.
    pub fn layer_images(&self) -> Vec<(String, Image)> {
        self.layers
            .iter()
            .map(|l| {
                let scale = 1.0 / l.iterations.max(1) as f64;
                (
                    l.name.clone(),
                    image_of(self.width, self.height, &l.sums, scale),
                )
            })
            .collect()
    }

    pub fn clear(&mut self) {
        self.sums.fill([0.0; 3]);
        self.layers.clear();
        self.dropped = 0;
    }

    /// The image `sum * scale`; with `scale = 1 / iterations` this is the mean
    /// over iterations, which is what a pixel's value means.
    pub fn to_image(&self, scale: f64) -> Image {
        image_of(self.width, self.height, &self.sums, scale)
    }

    /// Adds a tile-local buffer (row-major within the tile) and its dropped count.
    /// The values are added as they are: they were screened when the tile was
    /// filled (see [`TileBuffer`]).
    pub fn add_tile(&mut self, tile: &Tile, values: &[[f64; 3]], dropped: u64) {
        assert!(
            tile.x1 <= self.width && tile.y1 <= self.height,
            "Film::add_tile: tile {tile:?} outside a {}x{} film",
            self.width,
            self.height
        );
        assert_eq!(
            values.len(),
            tile.area(),
            "Film::add_tile: buffer length does not match tile {tile:?}"
        );
        let tw = tile.width() as usize;
        for (row, y) in (tile.y0..tile.y1).enumerate() {
            let start = y as usize * self.width as usize + tile.x0 as usize;
            let src = &values[row * tw..(row + 1) * tw];
            for (s, v) in self.sums[start..start + tw].iter_mut().zip(src) {
                add3(s, v);
            }
        }
        self.dropped += dropped;
    }

    pub fn add_tile_buffer(&mut self, buffer: &TileBuffer) {
        self.add_tile(&buffer.tile, &buffer.values, buffer.dropped);
    }
}

fn image_of(width: u32, height: u32, sums: &[[f64; 3]], scale: f64) -> Image {
    let pixels = sums
        .iter()
        .map(|s| {
            Rgb::new(
                (s[0] * scale) as f32,
                (s[1] * scale) as f32,
                (s[2] * scale) as f32,
            )
        })
        .collect();
    Image::from_pixels(width, height, pixels)
}

/// A rectangle of pixels, `x0..x1` by `y0..y1` (ends exclusive).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Tile {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl Tile {
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    pub fn area(&self) -> usize {
        pixel_count(self.width(), self.height())
    }
}

/// Splits a `width` x `height` image into tiles of at most `tile` x `tile`
/// pixels, row-major, edge tiles clipped. Every pixel lies in exactly one tile,
/// so rendering tiles in parallel and adding them in any order gives the same
/// sums bit for bit.
pub fn tiles(width: u32, height: u32, tile: u32) -> Vec<Tile> {
    assert!(tile > 0, "tiles: tile size must be positive");
    let mut out = Vec::new();
    for y0 in (0..height).step_by(tile as usize) {
        for x0 in (0..width).step_by(tile as usize) {
            out.push(Tile {
                x0,
                y0,
                x1: (x0 + tile).min(width),
                y1: (y0 + tile).min(height),
            });
        }
    }
    out
}

/// A tile's private accumulation buffer, for one rayon task; it applies the same
/// drop policy as [`Film::add`].
#[derive(Debug, Clone, PartialEq)]
pub struct TileBuffer {
    pub tile: Tile,
    pub values: Vec<[f64; 3]>,
    pub dropped: u64,
}

impl TileBuffer {
    /// Bytes per pixel of tile buffers covering a film.
    pub const PIXEL_BYTES: usize = std::mem::size_of::<[f64; 3]>();

    pub fn new(tile: Tile) -> Self {
        Self {
            tile,
            values: vec![[0.0; 3]; tile.area()],
            dropped: 0,
        }
    }

    /// Adds a sample at film coordinates (x, y), which must lie in the tile.
    #[inline(always)]
    pub fn add(&mut self, x: u32, y: u32, v: Rgb) {
        let t = self.tile;
        assert!(
            (t.x0..t.x1).contains(&x) && (t.y0..t.y1).contains(&y),
            "pixel ({x}, {y}) outside tile {t:?}"
        );
        let i = (y - t.y0) as usize * t.width() as usize + (x - t.x0) as usize;
        accumulate(&mut self.values[i], &mut self.dropped, v);
    }
}

fn accumulate(sum: &mut [f64; 3], dropped: &mut u64, v: Rgb) {
    if is_valid_sample(v) {
        add3(sum, &[v.x as f64, v.y as f64, v.z as f64]);
    } else {
        *dropped += 1;
    }
}

fn add3(s: &mut [f64; 3], v: &[f64; 3]) {
    s[0] += v[0];
    s[1] += v[1];
    s[2] += v[2];
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drops_and_counts_invalid_samples() {
        let mut film = Film::new(2, 1);
        film.add(0, 0, Rgb::new(1.0, 2.0, 3.0));
        film.add(0, 0, Rgb::new(f32::NAN, 0.0, 0.0));
        film.add(0, 0, Rgb::new(0.0, f32::INFINITY, 0.0));
        film.add(1, 0, Rgb::new(0.0, 0.0, f32::NEG_INFINITY));
        film.add(1, 0, Rgb::new(0.5, -1e-6, 0.5));
        film.add_index(1, Rgb::new(0.0, 0.0, 0.25));
        assert_eq!(film.dropped(), 4);
        assert_eq!(film.sums(), &[[1.0, 2.0, 3.0], [0.0, 0.0, 0.25]]);
    }

    #[test]
    fn negative_zero_is_accepted() {
        let mut film = Film::new(1, 1);
        film.add(0, 0, Rgb::new(-0.0, 0.0, 0.0));
        assert_eq!(film.dropped(), 0);
    }

    #[test]
    fn merge_adds_sums_and_dropped() {
        let mut a = Film::new(2, 1);
        let mut b = Film::new(2, 1);
        a.add(0, 0, Rgb::ONE);
        b.add(0, 0, Rgb::splat(2.0));
        b.add(1, 0, Rgb::new(0.0, 1.0, 0.0));
        b.add(1, 0, Rgb::NAN);
        a.add(1, 0, Rgb::NAN);
        a.merge(&b);
        assert_eq!(a.sums(), &[[3.0, 3.0, 3.0], [0.0, 1.0, 0.0]]);
        assert_eq!(a.dropped(), 2);
    }

    #[test]
    #[should_panic(expected = "films of different sizes")]
    fn merge_of_different_sizes_panics() {
        Film::new(2, 1).merge(&Film::new(1, 2));
    }

    #[test]
    fn clear_and_to_image_scale() {
        let mut film = Film::new(1, 2);
        film.add(0, 1, Rgb::new(2.0, 4.0, 6.0));
        film.add(0, 1, Rgb::new(2.0, 0.0, 0.0));
        let img = film.to_image(0.5);
        assert_eq!(img.get(0, 1), Rgb::new(2.0, 2.0, 3.0));
        assert_eq!(img.get(0, 0), Rgb::ZERO);
        film.add(0, 0, Rgb::NAN);
        film.clear();
        assert_eq!(film.dropped(), 0);
        assert!(film.sums().iter().all(|s| *s == [0.0; 3]));
    }

    #[test]
    fn tiles_cover_every_pixel_once() {
        let ts = tiles(5, 3, 2);
        assert_eq!(ts.len(), 6);
        assert_eq!(
            ts[2],
            Tile {
                x0: 4,
                y0: 0,
                x1: 5,
                y1: 2
            }
        );
        assert_eq!(
            ts[5],
            Tile {
                x0: 4,
                y0: 2,
                x1: 5,
                y1: 3
            }
        );
        assert_eq!(ts.iter().map(Tile::area).sum::<usize>(), 15);
        assert!(tiles(0, 4, 8).is_empty());
    }

    #[test]
    fn add_tile_places_values() {
        let mut film = Film::new(4, 3);
        let tile = Tile {
            x0: 1,
            y0: 1,
            x1: 3,
            y1: 3,
        };
        let values = [
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [3.0, 0.0, 0.0],
            [4.0, 0.0, 0.0],
        ];
        film.add_tile(&tile, &values, 7);
        let img = film.to_image(1.0);
        assert_eq!(img.get(1, 1).x, 1.0);
        assert_eq!(img.get(2, 1).x, 2.0);
        assert_eq!(img.get(1, 2).x, 3.0);
        assert_eq!(img.get(2, 2).x, 4.0);
        assert_eq!(img.mean().x, 10.0 / 12.0);
        assert_eq!(film.dropped(), 7);
    }

    #[test]
    fn tile_buffers_match_direct_adds() {
        let (w, h) = (7, 5);
        let sample = |x: u32, y: u32| Rgb::new(x as f32, y as f32, (x * y) as f32);
        let mut direct = Film::new(w, h);
        let mut tiled = Film::new(w, h);
        for t in tiles(w, h, 3) {
            let mut buf = TileBuffer::new(t);
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    buf.add(x, y, sample(x, y));
                    direct.add(x, y, sample(x, y));
                }
            }
            buf.add(t.x0, t.y0, Rgb::NAN);
            tiled.add_tile_buffer(&buf);
        }
        assert_eq!(tiled.sums(), direct.sums());
        assert_eq!(tiled.dropped(), tiles(w, h, 3).len() as u64);
    }

    #[test]
    #[should_panic(expected = "buffer length does not match")]
    fn add_tile_checks_buffer_length() {
        let tile = Tile {
            x0: 0,
            y0: 0,
            x1: 2,
            y1: 2,
        };
        Film::new(2, 2).add_tile(&tile, &[[0.0; 3]; 3], 0);
    }
}
