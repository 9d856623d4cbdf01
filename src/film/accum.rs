//! The film proper: per-pixel sums of a job's samples, its layers, and the image they
//! develop into. Imports `filter`, `image`, `sample` and `tile` (whose buffers it adds).

use glam::{Vec2, Vec3 as Rgb};

use super::filter::{PixelFilter, Taps};
use super::image::{pixel_count, Image};
use super::sample::{accumulate, add3, is_valid_sample};
use super::tile::{Tile, TileBuffer};

/// Per-pixel sums of radiance samples, in f64 so that thousands of iterations can
/// be summed without the later ones vanishing in rounding.
///
/// With the pixel box every sample adds to one pixel with weight one, camera samples
/// and light-tracing splats alike, and the image is the sums over the iteration
/// count. With a wider filter ([`PixelFilter`]) a camera sample adds to every pixel
/// within the radius times the filter's weight, and the weights are summed too
/// (`weights`): the camera image is the weighted sums over the summed weights, as in
/// Mitsuba 3. Splats go to `splats`, each spread by the filter's weights normalised to
/// sum to one (Mitsuba 3's adjoint integrators), and add their sums over the iteration
/// count to that.
#[derive(Debug, Clone, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    sums: Vec<[f64; 3]>,
    /// Summed camera-sample filter weights: empty until a filtered sample arrives.
    weights: Vec<f64>,
    /// Filtered splats: empty until one arrives.
    splats: Vec<[f64; 3]>,
    dropped: u64,
    layers: Vec<Layer>,
}

/// An extra image an integrator splits its estimate into (e.g. the contributions of
/// one technique). It counts its own iterations, so a layer that starts later (after a
/// restart from a checkpoint, which keeps only the main sums) still averages right.
/// Its camera samples are weighted by the main image's filter weights.
#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    pub name: String,
    pub iterations: u64,
    sums: Vec<[f64; 3]>,
    splats: Vec<[f64; 3]>,
}

impl Layer {
    pub fn sums(&self) -> &[[f64; 3]] {
        &self.sums
    }

    /// Filtered splats, if any arrived.
    pub fn splats(&self) -> Option<&[[f64; 3]]> {
        nonempty(&self.splats)
    }
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            sums: vec![[0.0; 3]; pixel_count(width, height)],
            weights: Vec::new(),
            splats: Vec::new(),
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
        let mut film = Self::new(0, 0);
        (film.width, film.height, film.sums, film.dropped) = (width, height, sums, dropped);
        film
    }

    /// Sets a filtered film's summed weights and splats (each empty, or one per pixel).
    pub fn set_filtered(&mut self, weights: Vec<f64>, splats: Vec<[f64; 3]>) {
        let n = self.sums.len();
        assert!(
            weights.is_empty() || weights.len() == n,
            "Film: weights size"
        );
        assert!(splats.is_empty() || splats.len() == n, "Film: splats size");
        (self.weights, self.splats) = (weights, splats);
    }

    /// Bytes the sums of a `width` x `height` film with `layers` layers hold (what a
    /// job's memory estimate counts for it).
    pub fn bytes_for(width: u32, height: u32, layers: usize) -> u64 {
        let per_image = pixel_count(width, height) * std::mem::size_of::<[f64; 3]>();
        (per_image * (1 + layers)) as u64
    }

    /// Bytes a filter wider than the pixel box adds to [`Film::bytes_for`]: the
    /// summed weights, and with `splats` a splat image per image.
    pub fn filter_bytes_for(width: u32, height: u32, layers: usize, splats: bool) -> u64 {
        let n = pixel_count(width, height) as u64;
        n * 8
            + if splats {
                n * 24 * (1 + layers as u64)
            } else {
                0
            }
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

    /// The summed camera-sample filter weights, if the film is filtered.
    pub fn weights(&self) -> Option<&[f64]> {
        nonempty(&self.weights)
    }

    /// The filtered splats, if any arrived.
    pub fn splats(&self) -> Option<&[[f64; 3]]> {
        nonempty(&self.splats)
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

    /// Adds a light-tracing splat at film position `p` (raster coordinates), and to
    /// `layer` if given. With the pixel box it goes to the pixel it lies in, as a
    /// camera sample does; with a wider filter to every pixel within the radius,
    /// the weights normalised to sum to one ([`PixelFilter::splat_taps`]).
    #[inline(always)]
    pub fn add_splat(&mut self, filter: &PixelFilter, p: Vec2, v: Rgb, layer: Option<usize>) {
        self.splat(filter, p, v, (true, layer));
    }

    /// A splat that belongs to `layer` alone, not to the main image: a radius layer
    /// (`radii`) is a whole other image, not a part of this one.
    #[inline(always)]
    pub fn add_layer_splat(&mut self, filter: &PixelFilter, p: Vec2, v: Rgb, layer: usize) {
        self.splat(filter, p, v, (false, Some(layer)));
    }

    /// [`add_splat`](Self::add_splat) to the main image if `main`, and to `layer`.
    #[inline(always)]
    fn splat(
        &mut self,
        filter: &PixelFilter,
        p: Vec2,
        v: Rgb,
        (main, layer): (bool, Option<usize>),
    ) {
        if filter.is_pixel_box() {
            let x = (p.x as u32).min(self.width - 1);
            let y = (p.y as u32).min(self.height - 1);
            let i = (y * self.width + x) as usize;
            if main {
                self.add_index(i, v);
            }
            if let Some(k) = layer {
                self.add_layer_index(k, i, v);
            }
            return;
        }
        self.add_filtered_splat(filter, p, v, (main, layer));
    }

    /// [`Film::splat`] with a filter wider than the pixel box.
    #[inline(never)]
    fn add_filtered_splat(
        &mut self,
        filter: &PixelFilter,
        p: Vec2,
        v: Rgb,
        (main, layer): (bool, Option<usize>),
    ) {
        if !is_valid_sample(v) {
            // Counted once, by the main image's own splat.
            self.dropped += main as u64;
            return;
        }
        let (w, h, n) = (self.width, self.height, self.sums.len());
        let (Some(tx), Some(ty)) = (filter.splat_taps(p.x, w), filter.splat_taps(p.y, h)) else {
            return;
        };
        let taps = (tx, ty);
        if main {
            spread(&mut self.splats, (w, n), taps, v);
        }
        if let Some(k) = layer {
            spread(&mut self.layers[k].splats, (w, n), taps, v);
        }
    }

    /// Adds another film of the same size (e.g. one worker's iterations).
    pub fn merge(&mut self, other: &Film) {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "Film::merge: films of different sizes"
        );
        add_all(&mut self.sums, &other.sums);
        add_weights(&mut self.weights, &other.weights);
        add_all(&mut self.splats, &other.splats);
        self.dropped += other.dropped;
        for l in &other.layers {
            let k = self.begin_layer(&l.name);
            let mine = &mut self.layers[k];
            mine.iterations += l.iterations - 1;
            add_all(&mut mine.sums, &l.sums);
            add_all(&mut mine.splats, &l.splats);
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
                    splats: Vec::new(),
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

    /// Adds a camera sample's share of a layer at film position `p`, in pixel (x, y):
    /// with a wider filter than the pixel box, to every pixel within the radius times
    /// the filter's weight (the main image sums the weights).
    pub fn add_layer_sample(
        &mut self,
        filter: &PixelFilter,
        layer: usize,
        (x, y, p): (u32, u32, Vec2),
        v: Rgb,
    ) {
        if filter.is_pixel_box() {
            self.add_layer_index(layer, (y * self.width + x) as usize, v);
        } else if is_valid_sample(v) {
            let (w, h, n) = (self.width, self.height, self.sums.len());
            let taps = (filter.taps(p.x, w), filter.taps(p.y, h));
            spread(&mut self.layers[layer].sums, (w, n), taps, v);
        }
    }

    /// The layers, in the order they were first begun.
    pub fn layers(&self) -> &[Layer] {
        &self.layers
    }

    /// Adds a whole layer (e.g. from saved sums). Panics if `sums` does not hold one
    /// value per pixel, or `splats` is neither empty nor that.
    pub fn push_layer(
        &mut self,
        name: &str,
        iterations: u64,
        sums: Vec<[f64; 3]>,
        splats: Vec<[f64; 3]>,
    ) {
        assert_eq!(sums.len(), self.sums.len(), "Film::push_layer: wrong size");
        assert!(splats.is_empty() || splats.len() == self.sums.len());
        self.layers.push(Layer {
            name: name.to_string(),
            iterations,
            sums,
            splats,
        });
    }

    /// Each layer's mean image.
    pub fn layer_images(&self) -> Vec<(String, Image)> {
        self.layers
            .iter()
            .map(|l| {
                let scale = 1.0 / l.iterations.max(1) as f64;
                let img = develop(
                    self.width,
                    self.height,
                    &l.sums,
                    &self.weights,
                    &l.splats,
                    scale,
                );
                (l.name.clone(), img)
            })
            .collect()
    }

    /// Empties the film, keeping its buffers (and so whether it is filtered).
    pub fn clear(&mut self) {
        self.sums.fill([0.0; 3]);
        self.weights.fill(0.0);
        self.splats.fill([0.0; 3]);
        self.layers.clear();
        self.dropped = 0;
    }

    /// The image: with the pixel box `sum * scale`, which with `scale = 1 /
    /// iterations` is the mean over iterations, what a pixel's value means; with a
    /// wider filter the weighted camera sums over their weights, plus the splats
    /// times `scale`.
    pub fn to_image(&self, scale: f64) -> Image {
        develop(
            self.width,
            self.height,
            &self.sums,
            &self.weights,
            &self.splats,
            scale,
        )
    }

    /// Pixel `i` of [`Film::to_image`]`(scale)`, in f64 (the image rounds it to f32).
    pub fn pixel(&self, i: usize, scale: f64) -> [f64; 3] {
        developed(&self.sums, &self.weights, &self.splats, scale, i)
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

    /// Adds a tile buffer: its region's values, and its weights if it is filtered.
    pub fn add_tile_buffer(&mut self, buffer: &TileBuffer) {
        self.add_tile(&buffer.region, &buffer.values, buffer.dropped);
        if buffer.weights.is_empty() {
            return;
        }
        let r = buffer.region;
        if self.weights.is_empty() {
            self.weights = vec![0.0; self.sums.len()];
        }
        let rw = r.width() as usize;
        for (row, y) in (r.y0..r.y1).enumerate() {
            let start = y as usize * self.width as usize + r.x0 as usize;
            let src = &buffer.weights[row * rw..(row + 1) * rw];
            for (s, w) in self.weights[start..start + rw].iter_mut().zip(src) {
                *s += w;
            }
        }
    }
}

fn nonempty<T>(v: &[T]) -> Option<&[T]> {
    (!v.is_empty()).then_some(v)
}

/// Adds `v` times each tap pair's weight to `image` (`width` wide, `pixels` in all,
/// allocated on first use).
fn spread(image: &mut Vec<[f64; 3]>, (width, pixels): (u32, usize), taps: (Taps, Taps), v: Rgb) {
    if image.is_empty() {
        *image = vec![[0.0; 3]; pixels];
    }
    let v = [v.x as f64, v.y as f64, v.z as f64];
    for (x, y, w) in Taps::pairs(&taps) {
        let i = y as usize * width as usize + x as usize;
        add3(&mut image[i], &[v[0] * w, v[1] * w, v[2] * w]);
    }
}

/// Adds `other` to `sums` pixel by pixel; an empty `other` adds nothing, and an empty
/// `sums` takes `other` as it is.
fn add_all(sums: &mut Vec<[f64; 3]>, other: &[[f64; 3]]) {
    if sums.is_empty() {
        sums.extend_from_slice(other);
        return;
    }
    for (s, o) in sums.iter_mut().zip(other) {
        add3(s, o);
    }
}

fn add_weights(sums: &mut Vec<f64>, other: &[f64]) {
    if sums.is_empty() {
        sums.extend_from_slice(other);
        return;
    }
    for (s, o) in sums.iter_mut().zip(other) {
        *s += o;
    }
}

/// The image of `sums` (and a filtered film's `weights` and `splats`, each empty if
/// there are none).
fn develop(
    width: u32,
    height: u32,
    sums: &[[f64; 3]],
    weights: &[f64],
    splats: &[[f64; 3]],
    scale: f64,
) -> Image {
    if weights.is_empty() && splats.is_empty() {
        return image_of(width, height, sums, scale);
    }
    let pixels = (0..sums.len())
        .map(|i| {
            let v = developed(sums, weights, splats, scale, i);
            Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32)
        })
        .collect();
    Image::from_pixels(width, height, pixels)
}

/// Pixel `i` of [`develop`]'s image, in f64.
fn developed(
    sums: &[[f64; 3]],
    weights: &[f64],
    splats: &[[f64; 3]],
    scale: f64,
    i: usize,
) -> [f64; 3] {
    let s = sums[i];
    // A pixel no sample has weighed is left as summed (zero), as Mitsuba does.
    let camera = match weights.get(i) {
        Some(&w) if w != 0.0 => [s[0] / w, s[1] / w, s[2] / w],
        Some(_) => s,
        None => [s[0] * scale, s[1] * scale, s[2] * scale],
    };
    let sp = splats.get(i).copied().unwrap_or([0.0; 3]);
    [
        camera[0] + sp[0] * scale,
        camera[1] + sp[1] * scale,
        camera[2] + sp[2] * scale,
    ]
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

#[cfg(test)]
mod tests;
