//! What a render produces: named planes, one value per pixel, row-major, row 0 at the top.
//!
//! Tracing always yields the hit planes (face, range, point, normal); shading and derived
//! planes (colour, linear colour, object id, optical-axis depth) are computed only when a
//! [`Planes`] request asks for them, so a depth-only data set never pays for shadow rays.

use glam::{DVec3, Vec3};

/// Face id of a pixel that sees nothing.
pub const NO_FACE: u32 = u32::MAX;

/// Object id of a pixel that sees nothing in the segmentation images (objects count from 1).
pub const BACKGROUND_OBJECT: u32 = 0;

/// Background colour of pixels that see nothing.
pub const BACKGROUND: [u8; 3] = [0, 0, 0];

/// A plane a frame can carry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Plane {
    /// 8-bit sRGB colour after shading.
    Colour,
    /// Linear colour after shading, before sRGB encoding (1.0 = full scale).
    LinearColour,
    /// Object id of the hit, counting from 1 in scene order; 0 = nothing hit.
    Object,
}

/// Which optional planes a render computes (the hit planes always come).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Planes {
    colour: bool,
    linear_colour: bool,
    object: bool,
}

impl Planes {
    /// Only the hit planes: no shading at all.
    pub const HITS: Planes = Planes {
        colour: false,
        linear_colour: false,
        object: false,
    };
    /// 8-bit colour and the hit planes: what most renders need.
    pub const COLOUR: Planes = Planes {
        colour: true,
        linear_colour: false,
        object: false,
    };
    /// Every plane.
    pub const ALL: Planes = Planes {
        colour: true,
        linear_colour: true,
        object: true,
    };

    /// This request with `plane` added.
    pub const fn with(mut self, plane: Plane) -> Planes {
        match plane {
            Plane::Colour => self.colour = true,
            Plane::LinearColour => self.linear_colour = true,
            Plane::Object => self.object = true,
        }
        self
    }

    /// Whether `plane` is requested.
    pub const fn contains(self, plane: Plane) -> bool {
        match plane {
            Plane::Colour => self.colour,
            Plane::LinearColour => self.linear_colour,
            Plane::Object => self.object,
        }
    }

    /// Whether any shaded plane is requested.
    pub const fn needs_shading(self) -> bool {
        self.colour || self.linear_colour
    }

    /// Bytes a frame with these planes holds for each pixel: the hit planes ([`Pixel`]: face,
    /// range, f64 point, f32 normal; 48 bytes) and each requested plane's value (colour 3,
    /// linear colour 12, object id 4). What sizes a render's memory (`OutputSet::bytes_per_pixel`).
    pub const fn bytes_per_pixel(self) -> usize {
        let mut bytes = size_of::<Pixel>();
        if self.colour {
            bytes += size_of::<[u8; 3]>();
        }
        if self.linear_colour {
            bytes += size_of::<[f32; 3]>();
        }
        if self.object {
            bytes += size_of::<u32>();
        }
        bytes
    }
}

/// What one pixel's ray hit: a view across the hit planes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pixel {
    /// Scene face hit, or [`NO_FACE`].
    pub face: u32,
    /// Euclidean distance from the camera ray's origin (the viewpoint for central cameras)
    /// to the hit, metres; +inf where nothing is hit.
    pub range: f32,
    /// Hit point in world metres (zero where nothing is hit).
    pub point: DVec3,
    /// Unit geometric normal of the face, turned towards the ray's origin (zero where nothing
    /// is hit).
    pub normal: Vec3,
}

impl Pixel {
    /// A pixel whose ray hits nothing.
    pub const MISS: Pixel = Pixel {
        face: NO_FACE,
        range: f32::INFINITY,
        point: DVec3::ZERO,
        normal: Vec3::ZERO,
    };

    /// Whether the ray hit a face.
    pub fn is_hit(&self) -> bool {
        self.face != NO_FACE
    }
}

/// The 8-bit and linear colour planes, where present, for in-place refinement.
pub(crate) type ShadedPlanesMut<'a> = (Option<&'a mut [[u8; 3]]>, Option<&'a mut [[f32; 3]]>);

/// A rendered image as named planes.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    hits: Vec<Pixel>,
    colour: Option<Vec<[u8; 3]>>,
    linear_colour: Option<Vec<[f32; 3]>>,
    object: Option<Vec<u32>>,
}

impl Frame {
    /// A frame of hit planes only, every pixel a miss.
    pub fn empty(width: u32, height: u32) -> Self {
        Self::from_hits(width, height, vec![Pixel::MISS; width as usize * height as usize])
    }

    /// A frame made of traced hits, `width × height` of them in row-major order.
    pub fn from_hits(width: u32, height: u32, hits: Vec<Pixel>) -> Self {
        assert_eq!(hits.len(), width as usize * height as usize, "one hit per pixel");
        Self {
            width,
            height,
            hits,
            colour: None,
            linear_colour: None,
            object: None,
        }
    }

    /// The hit planes, pixel by pixel.
    pub fn pixels(&self) -> &[Pixel] {
        &self.hits
    }

    /// The hit at pixel (u, v).
    pub fn pixel(&self, u: u32, v: u32) -> &Pixel {
        &self.hits[self.index(u, v)]
    }

    /// Row-major index of pixel (u, v).
    pub fn index(&self, u: u32, v: u32) -> usize {
        v as usize * self.width as usize + u as usize
    }

    /// Number of pixels whose ray hit a face.
    pub fn hit_count(&self) -> usize {
        self.hits.iter().filter(|p| p.is_hit()).count()
    }

    /// 8-bit sRGB colour, if it was requested.
    pub fn colour(&self) -> Option<&[[u8; 3]]> {
        self.colour.as_deref()
    }

    /// Linear colour before encoding (1.0 = full scale), if it was requested.
    pub fn linear_colour(&self) -> Option<&[[f32; 3]]> {
        self.linear_colour.as_deref()
    }

    /// Object ids (1-based, 0 = background), if requested.
    pub fn object(&self) -> Option<&[u32]> {
        self.object.as_deref()
    }

    /// Which planes this frame carries.
    pub fn planes(&self) -> Planes {
        let mut planes = Planes::HITS;
        for (plane, present) in [
            (Plane::Colour, self.colour.is_some()),
            (Plane::LinearColour, self.linear_colour.is_some()),
            (Plane::Object, self.object.is_some()),
        ] {
            if present {
                planes = planes.with(plane);
            }
        }
        planes
    }

    /// A frame of colour alone (an image made elsewhere, a noisy copy), for the PNG writer.
    pub fn from_colour(width: u32, height: u32, colour: Vec<[u8; 3]>) -> Self {
        let mut frame = Self::empty(width, height);
        frame.set_shading(Planes::COLOUR, Vec::new(), colour);
        frame
    }

    /// Sets the shaded planes, keeping only those `planes` asks for.
    pub(crate) fn set_shading(&mut self, planes: Planes, linear: Vec<[f32; 3]>, colour: Vec<[u8; 3]>) {
        self.colour = planes.contains(Plane::Colour).then_some(colour);
        self.linear_colour = planes.contains(Plane::LinearColour).then_some(linear);
    }

    /// Mutable shaded planes (8-bit, linear), for edge supersampling.
    pub(crate) fn shading_mut(&mut self) -> ShadedPlanesMut<'_> {
        (self.colour.as_deref_mut(), self.linear_colour.as_deref_mut())
    }

    /// Sets the object-id plane.
    pub(crate) fn set_object(&mut self, object: Vec<u32>) {
        self.object = Some(object);
    }
}
