use glam::Vec3 as Rgb;

/// A linear RGB image in f32, row-major, row 0 at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    width: u32,
    height: u32,
    pixels: Vec<Rgb>,
}

impl Image {
    /// Bytes the pixels of a `width` x `height` image hold.
    pub fn bytes_for(width: u32, height: u32) -> u64 {
        (pixel_count(width, height) * std::mem::size_of::<Rgb>()) as u64
    }

    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self::from_pixels(width, height, vec![Rgb::ZERO; pixel_count(width, height)])
    }

    /// Panics if `pixels.len() != width * height`: callers build the buffer
    /// themselves, so a mismatch is a programming error.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<Rgb>) -> Self {
        assert_eq!(
            pixels.len(),
            pixel_count(width, height),
            "Image::from_pixels: {} pixels given for a {width}x{height} image",
            pixels.len()
        );
        Self {
            width,
            height,
            pixels,
        }
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// `(width, height)`, the form `FilmError::SizeMismatch` reports.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    pub fn pixels(&self) -> &[Rgb] {
        &self.pixels
    }

    pub fn pixels_mut(&mut self) -> &mut [Rgb] {
        &mut self.pixels
    }

    pub fn into_pixels(self) -> Vec<Rgb> {
        self.pixels
    }

    pub fn get(&self, x: u32, y: u32) -> Rgb {
        self.pixels[self.index(x, y)]
    }

    pub fn set(&mut self, x: u32, y: u32, v: Rgb) {
        let i = self.index(x, y);
        self.pixels[i] = v;
    }

    /// Mean pixel value, summed in f64 so large images do not lose precision.
    /// Zero for an empty image.
    pub fn mean(&self) -> Rgb {
        if self.pixels.is_empty() {
            return Rgb::ZERO;
        }
        let sum = self.pixels.iter().fold([0.0f64; 3], |s, p| {
            [s[0] + p.x as f64, s[1] + p.y as f64, s[2] + p.z as f64]
        });
        let n = self.pixels.len() as f64;
        Rgb::new(
            (sum[0] / n) as f32,
            (sum[1] / n) as f32,
            (sum[2] / n) as f32,
        )
    }

    // A bad coordinate could otherwise alias a pixel in the next row.
    fn index(&self, x: u32, y: u32) -> usize {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside a {}x{} image",
            self.width,
            self.height
        );
        y as usize * self.width as usize + x as usize
    }
}

pub(crate) fn pixel_count(width: u32, height: u32) -> usize {
    width as usize * height as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn get_set_row_major_top_first() {
        let mut img = Image::new(3, 2);
        img.set(2, 1, Rgb::new(1.0, 2.0, 3.0));
        assert_eq!(img.get(2, 1), Rgb::new(1.0, 2.0, 3.0));
        assert_eq!(img.pixels()[5], Rgb::new(1.0, 2.0, 3.0));
        assert_eq!(img.get(0, 0), Rgb::ZERO);
    }

    #[test]
    fn mean_of_pixels() {
        let img = Image::from_pixels(2, 1, vec![Rgb::new(1.0, 0.0, 2.0), Rgb::new(3.0, 1.0, 0.0)]);
        assert_eq!(img.mean(), Rgb::new(2.0, 0.5, 1.0));
        assert_eq!(Image::new(0, 0).mean(), Rgb::ZERO);
    }

    #[test]
    #[should_panic(expected = "outside a 2x2 image")]
    fn out_of_range_panics() {
        Image::new(2, 2).get(2, 0);
    }

    #[test]
    #[should_panic(expected = "3 pixels given for a 2x2 image")]
    fn from_pixels_checks_length() {
        Image::from_pixels(2, 2, vec![Rgb::ZERO; 3]);
    }
}
