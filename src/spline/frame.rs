//! The image frame a deformation was made for: the pixel grid of the image it registers
//! (and, when known, that grid's place in physical space).
//!
//! A frame fit ([`crate::fit::frame`]) covers the frame with a mesh that reaches far beyond
//! it (a margin and far-field rings 16 times the frame's size), so the mesh's extent says
//! nothing about the image: the frame is recorded with the spline, kept by every copy and
//! edit, and written to the deformation file as the key `"frame"`. Fields, ITK and NGFF
//! exports default to its grid ([`ImageFrame::grid`]).
//!
//! Conventions: pixel `(i, j)` is centred at the point `(i, j)` of the reference plane, so a
//! `w x h` frame is the rectangle `[-1/2, w - 1/2] x [-1/2, h - 1/2]` and its pixel centres
//! run from `(0, 0)` to `(w - 1, h - 1)`. Physical coordinates, when given, are
//! `origin + spacing * (i, j)` per axis (ITK's and NGFF's convention for an identity
//! direction).

use serde::Serialize;

/// The largest frame side recorded (pixels): the raster limit of the image readers.
pub const MAX_FRAME_SIDE: f64 = 1_048_576.0;

/// The image frame of a deformation (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ImageFrame {
    /// Width and height in pixels.
    pub size: [f64; 2],
    /// The physical size of a pixel along x and y, when known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spacing: Option<[f64; 2]>,
    /// The physical position of pixel `(0, 0)`'s centre, when known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub origin: Option<[f64; 2]>,
    /// The physical unit of `spacing` and `origin` (e.g. `"micrometer"`), when known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
}

/// A frame that cannot be recorded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FrameError {
    /// The size is not positive, finite and at most [`MAX_FRAME_SIDE`].
    #[error("frame size {0:?}: width and height must be positive pixel counts up to 2^20")]
    Size([f64; 2]),
    /// A spacing is not positive and finite.
    #[error("frame spacing {0:?}: both must be positive finite numbers")]
    Spacing([f64; 2]),
    /// An origin is not finite.
    #[error("frame origin {0:?}: both must be finite numbers")]
    Origin([f64; 2]),
    /// A unit is empty or holds control characters.
    #[error("frame unit {0:?}: give a unit name such as \"micrometer\"")]
    Unit(String),
}

impl ImageFrame {
    /// A `w x h` frame in pixels, without physical coordinates.
    ///
    /// ```
    /// use trimorph::spline::ImageFrame;
    /// let f = ImageFrame::new([511.0, 300.0]).unwrap();
    /// assert_eq!(f.grid(), (511, 300));
    /// assert!(ImageFrame::new([0.0, 10.0]).is_err());
    /// ```
    pub fn new(size: [f64; 2]) -> Result<ImageFrame, FrameError> {
        let f = ImageFrame { size, spacing: None, origin: None, unit: None };
        f.validate()?;
        Ok(f)
    }

    /// Checks the ranges of every field.
    pub fn validate(&self) -> Result<(), FrameError> {
        let ok = |v: f64| v > 0.0 && v <= MAX_FRAME_SIDE;
        if !self.size.iter().all(|&v| ok(v)) {
            return Err(FrameError::Size(self.size));
        }
        if let Some(s) = self.spacing.filter(|s| !s.iter().all(|v| *v > 0.0 && v.is_finite())) {
            return Err(FrameError::Spacing(s));
        }
        if let Some(o) = self.origin.filter(|o| !o.iter().all(|v| v.is_finite())) {
            return Err(FrameError::Origin(o));
        }
        if self.unit.as_deref().is_some_and(|u| u.is_empty() || u.chars().any(char::is_control)) {
            return Err(FrameError::Unit(self.unit.clone().unwrap_or_default()));
        }
        Ok(())
    }

    /// The pixel grid covering the frame: `(ceil(w), ceil(h))` pixels (a frame of whole
    /// pixels is its own grid).
    pub fn grid(&self) -> (u32, u32) {
        (self.size[0].ceil() as u32, self.size[1].ceil() as u32)
    }

    /// Where the frame's pixels sit in physical space: the recorded spacing, origin and unit,
    /// each defaulting to pixels (spacing 1, origin 0, no unit).
    pub fn physical(&self) -> Physical {
        Physical {
            spacing: self.spacing.unwrap_or([1.0; 2]),
            origin: self.origin.unwrap_or([0.0; 2]),
            unit: self.unit.clone(),
        }
    }

    /// The frame with `p` recorded as its physical placement (spacing, origin and unit).
    pub fn with_physical(mut self, p: &Physical) -> Result<ImageFrame, FrameError> {
        p.validate()?;
        self.spacing = Some(p.spacing);
        self.origin = Some(p.origin);
        self.unit = p.unit.clone();
        Ok(self)
    }
}

/// The physical placement of a pixel grid, with an identity direction (ITK's and NGFF's
/// convention): pixel centre `(i, j)` lies at `origin + spacing * (i, j)` per axis, in
/// `unit`s. A displacement `d` in pixels is `spacing * d` in physical units.
///
/// ```
/// use trimorph::spline::Physical;
/// let p = Physical { spacing: [0.5, 0.25], origin: [10.0, -2.0], unit: Some("micrometer".into()) };
/// assert_eq!(p.point([4.0, 8.0]), [12.0, 0.0]);
/// assert_eq!(p.vector([4.0, 8.0]), [2.0, 2.0]);
/// assert!(Physical::pixels().is_pixels());
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Physical {
    /// The distance between pixel centres along x and y, in `unit`s (positive, finite).
    pub spacing: [f64; 2],
    /// The physical position of pixel `(0, 0)`'s centre (finite).
    pub origin: [f64; 2],
    /// The unit of `spacing` and `origin` (e.g. `"micrometer"`); `None`: unstated.
    pub unit: Option<String>,
}

impl Default for Physical {
    fn default() -> Physical {
        Physical::pixels()
    }
}

impl Physical {
    /// Pixel units: spacing 1, origin 0, no unit.
    pub fn pixels() -> Physical {
        Physical { spacing: [1.0; 2], origin: [0.0; 2], unit: None }
    }

    /// Whether this is [`Physical::pixels`] (spacing exactly 1, origin exactly 0, no unit).
    pub fn is_pixels(&self) -> bool {
        *self == Physical::pixels()
    }

    /// Checks that the spacing is positive and finite and the origin finite.
    pub fn validate(&self) -> Result<(), FrameError> {
        if !self.spacing.iter().all(|v| *v > 0.0 && v.is_finite()) {
            return Err(FrameError::Spacing(self.spacing));
        }
        if !self.origin.iter().all(|v| v.is_finite()) {
            return Err(FrameError::Origin(self.origin));
        }
        if self.unit.as_deref().is_some_and(|u| u.is_empty() || u.chars().any(char::is_control)) {
            return Err(FrameError::Unit(self.unit.clone().unwrap_or_default()));
        }
        Ok(())
    }

    /// The physical position of the pixel-coordinate point `p`.
    pub fn point(&self, p: [f64; 2]) -> [f64; 2] {
        [self.origin[0] + self.spacing[0] * p[0], self.origin[1] + self.spacing[1] * p[1]]
    }

    /// The physical length of the pixel-coordinate vector `v` (per axis).
    pub fn vector(&self, v: [f64; 2]) -> [f64; 2] {
        [self.spacing[0] * v[0], self.spacing[1] * v[1]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_out_of_range_are_refused() {
        assert!(ImageFrame::new([f64::NAN, 3.0]).is_err());
        assert!(ImageFrame::new([3.0, 2e6]).is_err());
        let mut f = ImageFrame::new([10.5, 3.0]).unwrap();
        assert_eq!(f.grid(), (11, 3));
        f.spacing = Some([0.5, 0.0]);
        assert_eq!(f.validate(), Err(FrameError::Spacing([0.5, 0.0])));
        f.spacing = Some([0.5, 0.25]);
        f.origin = Some([f64::INFINITY, 0.0]);
        assert!(f.validate().is_err());
    }
}
