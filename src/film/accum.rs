use glam::{Vec2, Vec3 as Rgb};

use super::filter::{PixelFilter, Taps};
use super::image::{pixel_count, Image};
use super::tile::{Tile, TileBuffer};

/// Whether a sample may enter the film. NaN, infinite or negative radiance is a
/// bug upstream; averaging it in would hide the bug, so it is dropped and counted.
pub fn is_valid_sample(v: Rgb) -> bool {
    v.is_finite() && v.cmpge(Rgb::ZERO).all()
}

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
        if filter.is_pixel_box() {
            let x = (p.x as u32).min(self.width - 1);
            let y = (p.y as u32).min(self.height - 1);
            let i = (y * self.width + x) as usize;
            self.add_index(i, v);
            if let Some(k) = layer {
                self.add_layer_index(k, i, v);
            }
            return;
        }
        self.add_filtered_splat(filter, p, v, layer);
    }

    /// [`add_splat`](Self::add_splat) with a filter wider than the pixel box.
    #[inline(never)]
    fn add_filtered_splat(&mut self, filter: &PixelFilter, p: Vec2, v: Rgb, layer: Option<usize>) {
        if !is_valid_sample(v) {
            self.dropped += 1;
            return;
        }
        let (w, h, n) = (self.width, self.height, self.sums.len());
        let (Some(tx), Some(ty)) = (filter.splat_taps(p.x, w), filter.splat_taps(p.y, h)) else {
            return;
        };
        let taps = (tx, ty);
        spread(&mut self.splats, (w, n), taps, v);
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
            let s = sums[i];
            // A pixel no sample has weighed is left as summed (zero), as Mitsuba does.
            let camera = match weights.get(i) {
                Some(&w) if w != 0.0 => [s[0] / w, s[1] / w, s[2] / w],
                Some(_) => s,
                None => [s[0] * scale, s[1] * scale, s[2] * scale],
            };
            let sp = splats.get(i).copied().unwrap_or([0.0; 3]);
            Rgb::new(
                (camera[0] + sp[0] * scale) as f32,
                (camera[1] + sp[1] * scale) as f32,
                (camera[2] + sp[2] * scale) as f32,
            )
        })
        .collect();
    Image::from_pixels(width, height, pixels)
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

pub(super) fn accumulate(sum: &mut [f64; 3], dropped: &mut u64, v: Rgb) {
    if is_valid_sample(v) {
        add3(sum, &[v.x as f64, v.y as f64, v.z as f64]);
    } else {
        *dropped += 1;
    }
}

pub(super) fn add3(s: &mut [f64; 3], v: &[f64; 3]) {
    s[0] += v[0];
    s[1] += v[1];
    s[2] += v[2];
}

#[cfg(test)]
mod tests {
    use super::super::filter::Filter;
    use super::*;

    const FILTERS: [Filter; 6] = [
        Filter::Box { radius: 0.5 },
        Filter::Box { radius: 1.5 },
        Filter::Tent { radius: 1.25 },
        Filter::Gaussian { stddev: 0.5 },
        Filter::Mitchell {
            b: 1.0 / 3.0,
            c: 1.0 / 3.0,
        },
        Filter::Lanczos { lobes: 3 },
    ];

    /// A film of `w` x `h` with `m` x `m` camera samples per pixel on a regular grid,
    /// of radiance `l(x, y)`, added through tile buffers as the renderer does.
    fn camera_film(
        filter: &PixelFilter,
        (w, h): (u32, u32),
        m: u32,
        l: &dyn Fn(f32, f32) -> Rgb,
    ) -> Film {
        let mut film = Film::new(w, h);
        for t in crate::film::tiles(w, h, 4) {
            let mut buf = TileBuffer::for_filter(t, filter, w, h);
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    for (i, j) in (0..m).flat_map(|i| (0..m).map(move |j| (i, j))) {
                        let p = Vec2::new(
                            x as f32 + (i as f32 + 0.5) / m as f32,
                            y as f32 + (j as f32 + 0.5) / m as f32,
                        );
                        buf.add_sample(filter, (x, y, p), l(p.x, p.y));
                    }
                }
            }
            film.add_tile_buffer(&buf);
        }
        film
    }

    /// The same radiance as light-tracing splats: `m` x `m` per pixel of unit area,
    /// each carrying 1 / m^2 of it (one "iteration").
    fn splat_film(
        filter: &PixelFilter,
        (w, h): (u32, u32),
        m: u32,
        l: &dyn Fn(f32, f32) -> Rgb,
    ) -> Film {
        let mut film = Film::new(w, h);
        let n = (w * m, h * m);
        for (i, j) in (0..n.0).flat_map(|i| (0..n.1).map(move |j| (i, j))) {
            let p = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
            film.add_splat(filter, p, l(p.x, p.y) / (m * m) as f32, None);
        }
        film
    }

    /// Normalisation: a constant radiance gives the constant in every pixel, edges
    /// included, with every filter, from camera samples (weights over their sum). From
    /// splats (weights normalised per splat, as Mitsuba 3 does) it gives the constant
    /// where no splat reaching the pixel is clipped by the film's edge (2 radii in),
    /// and the image keeps the whole energy.
    #[test]
    fn constant_radiance_stays_constant_with_every_filter() {
        let (w, h) = (16, 14);
        let c = Rgb::new(0.25, 1.0, 3.0);
        for f in FILTERS {
            let filter = PixelFilter::new(f);
            let camera = camera_film(&filter, (w, h), 3, &|_, _| c).to_image(1.0 / 9.0);
            let splats = splat_film(&filter, (w, h), 16, &|_, _| c).to_image(1.0);
            let inside = 2.0 * f.radius();
            for y in 0..h {
                for x in 0..w {
                    let d = (camera.get(x, y) - c).abs().max_element();
                    assert!(d <= 3e-6, "{f:?} camera ({x}, {y}): {}", camera.get(x, y));
                    let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
                    let interior = [cx, w as f64 - cx, cy, h as f64 - cy]
                        .iter()
                        .all(|&d| d >= inside);
                    let d = (splats.get(x, y) - c).abs().max_element();
                    assert!(
                        !interior || d <= 6e-3,
                        "{f:?} splats ({x}, {y}): {}",
                        splats.get(x, y)
                    );
                }
            }
            let energy = splats.mean() / c;
            assert!(
                (energy - Rgb::ONE).abs().max_element() < 1e-5,
                "{f:?}: {energy}"
            );
        }
    }

    /// A vertical step, radiance 1 left of x = 6.3 and 0 right of it: from camera
    /// samples each pixel is the filter's share left of the step among its share
    /// inside the film (tent in closed form, Gaussian by a fine sum of its closed
    /// form). Splats give the same away from the edges with filters whose shifted
    /// copies sum to one (the tent of radius 1, Mitchell's family), where Mitsuba's
    /// per-splat normalisation divides by one.
    #[test]
    fn a_step_is_the_filters_convolution() {
        // Row h / 2 is two radii from the top and bottom edges.
        let (w, h, edge) = (12u32, 9u32, 6.3f64);
        let step = |x: f32, _: f32| Rgb::splat(if (x as f64) < edge { 1.0 } else { 0.0 });
        // The tent's integral from -r to t, in closed form.
        let tent_cdf = |r: f64, t: f64| {
            let t = t.clamp(-r, r);
            if t <= 0.0 {
                (t + r) * (t + r) / (2.0 * r)
            } else {
                r - (r - t) * (r - t) / (2.0 * r)
            }
        };
        let tent = |a: f64, b: f64| tent_cdf(1.25, b) - tent_cdf(1.25, a);
        let tent1 = |a: f64, b: f64| tent_cdf(1.0, b) - tent_cdf(1.0, a);
        let fine = |f: &dyn Fn(f64) -> f64, a: f64, b: f64| {
            let n = 200_000;
            let h = (b - a) / n as f64;
            (0..n).map(|i| f(a + (i as f64 + 0.5) * h) * h).sum::<f64>()
        };
        let gauss =
            |a: f64, b: f64| fine(&|x| ((-2.0 * x * x).exp() - (-8.0f64).exp()).max(0.0), a, b);
        // Mitchell with B = C = 1/3, [MN88] eq. 8 written out again.
        let mitchell = |a: f64, b: f64| {
            let k = |x: f64| {
                let x = x.abs();
                match x {
                    x if x < 1.0 => (7.0 * x * x * x - 12.0 * x * x + 16.0 / 3.0) / 6.0,
                    x if x < 2.0 => {
                        (-7.0 / 3.0 * x * x * x + 12.0 * x * x - 20.0 * x + 32.0 / 3.0) / 6.0
                    }
                    _ => 0.0,
                }
            };
            fine(&k, a, b)
        };
        let third = 1.0 / 3.0;
        // (filter, its integral over [a, b], whether splats are checked too)
        type Case<'a> = (Filter, &'a dyn Fn(f64, f64) -> f64, bool);
        let cases: [Case; 4] = [
            (Filter::Tent { radius: 1.25 }, &tent, false),
            (Filter::Gaussian { stddev: 0.5 }, &gauss, false),
            (Filter::Tent { radius: 1.0 }, &tent1, true),
            (Filter::Mitchell { b: third, c: third }, &mitchell, true),
        ];
        for (f, integral, splats_too) in cases {
            let filter = PixelFilter::new(f);
            let m = 40;
            let camera = camera_film(&filter, (w, h), m, &step).to_image(1.0);
            let splats = splat_film(&filter, (w, h), m, &step).to_image(1.0);
            for x in 0..w {
                let c = x as f64 + 0.5;
                let want = integral(-c, edge - c) / integral(-c, w as f64 - c);
                let got = camera.get(x, h / 2).x as f64;
                assert!(
                    (got - want).abs() < 2e-3,
                    "{f:?} camera pixel {x}: {got} vs {want}"
                );
                let inside = c >= 2.0 * f.radius() && w as f64 - c >= 2.0 * f.radius();
                if splats_too && inside {
                    let got = splats.get(x, h / 2).x as f64;
                    assert!(
                        (got - want).abs() < 2e-3,
                        "{f:?} splats pixel {x}: {got} vs {want}"
                    );
                }
            }
        }
    }

    /// With the pixel box nothing but the sums exists: splats land in them, the
    /// image is sums times the scale, bit for bit as before filters.
    #[test]
    fn the_pixel_box_keeps_one_sum_per_pixel() {
        let filter = PixelFilter::new(Filter::default());
        let mut film = Film::new(3, 2);
        film.add_splat(&filter, Vec2::new(2.9, 1.2), Rgb::splat(0.3), None);
        film.add_splat(&filter, Vec2::new(3.0, 2.0), Rgb::splat(0.1), None);
        let mut buf = TileBuffer::for_filter(crate::film::tiles(3, 2, 4)[0], &filter, 3, 2);
        buf.add_sample(&filter, (2, 1, Vec2::new(2.5, 1.5)), Rgb::splat(0.7));
        film.add_tile_buffer(&buf);
        assert_eq!((film.weights(), film.splats()), (None, None));
        // Splats to the pixel they lie in (the film's edge belongs to the last pixel).
        let want = 0.3f32 as f64 + 0.1f32 as f64 + 0.7f32 as f64;
        assert_eq!(film.sums()[5], [want; 3]);
        assert_eq!(
            film.to_image(0.5).get(2, 1),
            Rgb::splat((want * 0.5) as f32)
        );
    }

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
