//! What a render produces, pixel by pixel, whichever backend made it.

use glam::DVec3;

/// Face id of a pixel that sees nothing.
pub const NO_FACE: u32 = u32::MAX;

/// Background colour of pixels that see nothing.
pub const BACKGROUND: [u8; 3] = [0, 0, 0];

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pixel {
    pub colour: [u8; 3],
    /// Euclidean distance from the camera ray's origin (the viewpoint for central cameras) to
    /// the hit, metres; +inf where nothing is hit.
    pub range: f32,
    /// Scene face hit, or `NO_FACE`.
    pub face: u32,
    /// Hit point in world metres (meaningless where `face == NO_FACE`).
    pub point: DVec3,
}

impl Pixel {
    pub const MISS: Pixel = Pixel {
        colour: BACKGROUND,
        range: f32::INFINITY,
        face: NO_FACE,
        point: DVec3::ZERO,
    };

    pub fn is_hit(&self) -> bool {
        self.face != NO_FACE
    }
}

/// A rendered image, row-major, row 0 at the top.
#[derive(Debug, Clone)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pixels: Vec<Pixel>,
}

impl Frame {
    pub fn empty(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![Pixel::MISS; width as usize * height as usize],
        }
    }

    pub fn pixels(&self) -> &[Pixel] {
        &self.pixels
    }

    pub fn pixels_mut(&mut self) -> &mut [Pixel] {
        &mut self.pixels
    }

    pub fn pixel(&self, u: u32, v: u32) -> &Pixel {
        &self.pixels[v as usize * self.width as usize + u as usize]
    }

    pub fn hit_count(&self) -> usize {
        self.pixels.iter().filter(|p| p.is_hit()).count()
    }
}
