//! Tiles of the image and the private buffers that parallel tasks render them into.

use glam::{Vec2, Vec3 as Rgb};

use super::filter::{PixelFilter, Taps};
use super::image::pixel_count;
use super::sample::{accumulate, add3, is_valid_sample};

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

    /// The tile grown by `border` pixels on each side, within a `width` x `height` film.
    pub fn grown(&self, border: u32, width: u32, height: u32) -> Tile {
        Tile {
            x0: self.x0.saturating_sub(border),
            y0: self.y0.saturating_sub(border),
            x1: self.x1.saturating_add(border).min(width),
            y1: self.y1.saturating_add(border).min(height),
        }
    }
}

/// Splits a `width` x `height` image into tiles of at most `tile` x `tile`
/// pixels, row-major, edge tiles clipped. Every pixel lies in exactly one tile,
/// so rendering tiles in parallel and adding them in a fixed order gives the same
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
/// drop policy as [`super::Film::add`]. With a filter wider than the pixel box it
/// covers the pixels the tile's samples reach (`region`, the tile and a border) and
/// holds their summed filter weights too.
#[derive(Debug, Clone, PartialEq)]
pub struct TileBuffer {
    pub tile: Tile,
    /// The pixels `values` (and `weights`) hold, row-major.
    pub region: Tile,
    pub values: Vec<[f64; 3]>,
    /// Summed filter weights (empty with the pixel box, whose weight is one sample).
    pub weights: Vec<f64>,
    pub dropped: u64,
    /// The film's size, which clips a filter's footprint.
    film: (u32, u32),
}

impl TileBuffer {
    /// Bytes per pixel of pixel-box tile buffers covering a film.
    pub const PIXEL_BYTES: usize = std::mem::size_of::<[f64; 3]>();

    /// A buffer for the pixel box: one value per pixel of the tile.
    pub fn new(tile: Tile) -> Self {
        Self {
            tile,
            region: tile,
            values: vec![[0.0; 3]; tile.area()],
            weights: Vec::new(),
            dropped: 0,
            film: (tile.x1, tile.y1),
        }
    }

    /// A buffer for the samples of `tile` on a `width` x `height` film with `filter`.
    pub fn for_filter(tile: Tile, filter: &PixelFilter, width: u32, height: u32) -> Self {
        if filter.is_pixel_box() {
            return Self::new(tile);
        }
        let region = tile.grown(filter.border(), width, height);
        Self {
            tile,
            region,
            values: vec![[0.0; 3]; region.area()],
            weights: vec![0.0; region.area()],
            dropped: 0,
            film: (width, height),
        }
    }

    /// Bytes a buffer of a `tile` x `tile` tile takes with `filter` (its values and
    /// weights, over the tile and its border).
    pub fn bytes_for(tile: u32, filter: &PixelFilter) -> usize {
        let side = (tile + 2 * filter.border()) as usize;
        let per_pixel = if filter.is_pixel_box() {
            Self::PIXEL_BYTES
        } else {
            Self::PIXEL_BYTES + std::mem::size_of::<f64>()
        };
        side * side * per_pixel
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

    /// Adds the camera sample of pixel (x, y), at film position `p`: to the pixel, or
    /// with a buffer for a wider filter ([`TileBuffer::for_filter`]), spread by it.
    #[inline(always)]
    pub fn add_sample(&mut self, filter: &PixelFilter, (x, y, p): (u32, u32, Vec2), v: Rgb) {
        if self.weights.is_empty() {
            self.add(x, y, v);
        } else {
            self.add_filtered(filter, p, v);
        }
    }

    /// Adds a camera sample at film position `p` (in the tile) with `filter`: to every
    /// pixel within the radius, times the filter's weight, which is summed too.
    #[inline]
    pub fn add_filtered(&mut self, filter: &PixelFilter, p: Vec2, v: Rgb) {
        if !is_valid_sample(v) {
            self.dropped += 1;
            return;
        }
        let (tx, ty) = (filter.taps(p.x, self.film.0), filter.taps(p.y, self.film.1));
        let r = self.region;
        assert!(
            tx.count == 0 || (tx.first >= r.x0 && tx.first + tx.count as u32 <= r.x1),
            "sample at {p} reaches beyond tile region {r:?}"
        );
        assert!(ty.count == 0 || (ty.first >= r.y0 && ty.first + ty.count as u32 <= r.y1));
        let v = [v.x as f64, v.y as f64, v.z as f64];
        let rw = r.width() as usize;
        for (x, y, w) in Taps::pairs(&(tx, ty)) {
            let i = (y - r.y0) as usize * rw + (x - r.x0) as usize;
            add3(&mut self.values[i], &[v[0] * w, v[1] * w, v[2] * w]);
            self.weights[i] += w;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::filter::Filter;
    use super::super::Film;
    use super::*;

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

    /// Filtered tiles reach into their neighbours: whatever the tile size, the film
    /// gets every sample's weights on every pixel within the radius.
    #[test]
    fn filtered_tiles_of_any_size_give_the_same_film() {
        let (w, h) = (9, 7);
        let filter = PixelFilter::new(Filter::Gaussian { stddev: 0.5 });
        let film_of = |tile: u32| {
            let mut film = Film::new(w, h);
            for t in tiles(w, h, tile) {
                let mut buf = TileBuffer::for_filter(t, &filter, w, h);
                for y in t.y0..t.y1 {
                    for x in t.x0..t.x1 {
                        let p = Vec2::new(x as f32 + 0.25, y as f32 + 0.75);
                        buf.add_filtered(&filter, p, Rgb::new(1.0, x as f32, y as f32));
                    }
                }
                film.add_tile_buffer(&buf);
            }
            film
        };
        let (one, big) = (film_of(1), film_of(16));
        for (a, b) in one.sums().iter().zip(big.sums()) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-12 * b[c].abs().max(1.0));
            }
        }
        let (wa, wb) = (one.weights().unwrap(), big.weights().unwrap());
        for (a, b) in wa.iter().zip(wb) {
            assert!((a - b).abs() < 1e-12);
        }
        // An interior pixel sees 4 x 4 or more samples' weights.
        let mid = 3 * w as usize + 4;
        let expected: f64 = (0..w)
            .flat_map(|x| (0..h).map(move |y| (x, y)))
            .map(|(x, y)| {
                let g = Filter::Gaussian { stddev: 0.5 };
                g.eval(4.5 - (x as f64 + 0.25)) * g.eval(3.5 - (y as f64 + 0.75))
            })
            .sum();
        assert!(
            (wb[mid] - expected).abs() < 1e-12,
            "{} vs {expected}",
            wb[mid]
        );
    }
}
