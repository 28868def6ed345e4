//! What an edit did to the canvas, in the form the app needs: the changed pixels' painted
//! colours (to turn into BRDF samples) and the rectangle of the texture to upload.

/// A rectangle of pixels, `x0..x1` × `y0..y1` (ends exclusive). Empty when `x0 >= x1` or
/// `y0 >= y1`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct PixelRect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl PixelRect {
    /// The empty rectangle at the origin.
    pub const EMPTY: Self = Self {
        x0: 0,
        y0: 0,
        x1: 0,
        y1: 0,
    };

    pub fn new(x0: u32, y0: u32, x1: u32, y1: u32) -> Self {
        Self { x0, y0, x1, y1 }
    }

    pub fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    pub fn contains(&self, x: u32, y: u32) -> bool {
        (self.x0..self.x1).contains(&x) && (self.y0..self.y1).contains(&y)
    }

    /// The pixels in both rectangles (empty if they do not meet).
    pub fn intersect(&self, other: &Self) -> Self {
        let r = Self {
            x0: self.x0.max(other.x0),
            y0: self.y0.max(other.y0),
            x1: self.x1.min(other.x1),
            y1: self.y1.min(other.y1),
        };
        if r.is_empty() { Self::EMPTY } else { r }
    }

    /// The smallest rectangle holding both (an empty one adds nothing).
    pub fn union(&self, other: &Self) -> Self {
        if self.is_empty() {
            return *other;
        }
        if other.is_empty() {
            return *self;
        }
        Self {
            x0: self.x0.min(other.x0),
            y0: self.y0.min(other.y0),
            x1: self.x1.max(other.x1),
            y1: self.y1.max(other.y1),
        }
    }
}

/// One pixel whose painted state or colour changed. From the canvas, `None` means "not
/// painted" (coverage 0, the pixel shows the base) and `Some(c)` is a painted pixel's colour.
/// The app restates each one under its view's rule for unpainted pixels before the worker
/// hears it ([`crate::worker::Command::Pixels`]): there `None` means the pixel says nothing
/// (it gives no sample) and `Some` is the linear RGB radiance it shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelChange {
    /// Row-major pixel index.
    pub pixel: u32,
    pub before: Option<[f32; 3]>,
    pub after: Option<[f32; 3]>,
}

/// The pixels a batch of edits changed, in increasing pixel order, one entry per pixel with
/// the state it had when the batch began. `dirty` is the smallest rectangle holding them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CanvasChanges {
    pub dirty: PixelRect,
    pub pixels: Vec<PixelChange>,
}

impl CanvasChanges {
    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }
}
