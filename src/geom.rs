//! Points and vectors of the plane, in pixels: two types, as positions and displacements are
//! two different things (a point plus a vector is a point, a point minus a point is a
//! vector, and two points do not add).
//!
//! Coordinates follow the rest of the crate: x to the right, y down, pixel `(i, j)` centred at
//! `(i, j)`. Both types are `#[repr(C)]` pairs of `f64` and convert for free to and from the
//! `[f64; 2]` arrays that inner loops keep ([`Point::to_array`], `From`).
//!
//! ```
//! use trimorph::geom::{Point, Vector};
//! let p = Point::new(3.0, 4.0);
//! let q = p + Vector::new(1.0, -2.0);
//! assert_eq!(q, Point::new(4.0, 2.0));
//! assert_eq!(q - p, Vector::new(1.0, -2.0));
//! assert_eq!((q - p).length(), 5f64.sqrt());
//! let a: [f64; 2] = q.into();
//! assert_eq!(Point::from(a), q);
//! ```

use std::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};

/// A position in the plane, px.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub struct Point {
    /// x, px (to the right).
    pub x: f64,
    /// y, px (down).
    pub y: f64,
}

/// A displacement in the plane, px.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[repr(C)]
pub struct Vector {
    /// x component, px.
    pub x: f64,
    /// y component, px.
    pub y: f64,
}

impl Point {
    /// The origin.
    pub const ORIGIN: Point = Point { x: 0.0, y: 0.0 };

    /// The point `(x, y)`.
    pub const fn new(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    /// `[x, y]`.
    pub const fn to_array(self) -> [f64; 2] {
        [self.x, self.y]
    }

    /// The vector from the origin to the point.
    pub const fn to_vector(self) -> Vector {
        Vector { x: self.x, y: self.y }
    }

    /// Both coordinates finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }

    /// The Euclidean distance to `other`.
    pub fn distance(self, other: Point) -> f64 {
        (self - other).length()
    }

    /// `(1 - t) self + t other`.
    pub fn lerp(self, other: Point, t: f64) -> Point {
        self + (other - self) * t
    }
}

impl Vector {
    /// The zero vector.
    pub const ZERO: Vector = Vector { x: 0.0, y: 0.0 };

    /// The vector `(x, y)`.
    pub const fn new(x: f64, y: f64) -> Vector {
        Vector { x, y }
    }

    /// `[x, y]`.
    pub const fn to_array(self) -> [f64; 2] {
        [self.x, self.y]
    }

    /// The Euclidean length.
    pub fn length(self) -> f64 {
        self.x.hypot(self.y)
    }

    /// The dot product.
    pub fn dot(self, other: Vector) -> f64 {
        self.x * other.x + self.y * other.y
    }

    /// The z component of the cross product (positive when `other` turns counterclockwise
    /// from `self` in a y-up frame, clockwise on screen with y down).
    pub fn cross(self, other: Vector) -> f64 {
        self.x * other.y - self.y * other.x
    }

    /// Both components finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

impl From<[f64; 2]> for Point {
    fn from([x, y]: [f64; 2]) -> Point {
        Point { x, y }
    }
}

impl From<Point> for [f64; 2] {
    fn from(p: Point) -> [f64; 2] {
        p.to_array()
    }
}

impl From<[f64; 2]> for Vector {
    fn from([x, y]: [f64; 2]) -> Vector {
        Vector { x, y }
    }
}

impl From<Vector> for [f64; 2] {
    fn from(v: Vector) -> [f64; 2] {
        v.to_array()
    }
}

impl Add<Vector> for Point {
    type Output = Point;
    fn add(self, v: Vector) -> Point {
        Point { x: self.x + v.x, y: self.y + v.y }
    }
}

impl AddAssign<Vector> for Point {
    fn add_assign(&mut self, v: Vector) {
        *self = *self + v;
    }
}

impl Sub<Vector> for Point {
    type Output = Point;
    fn sub(self, v: Vector) -> Point {
        Point { x: self.x - v.x, y: self.y - v.y }
    }
}

impl SubAssign<Vector> for Point {
    fn sub_assign(&mut self, v: Vector) {
        *self = *self - v;
    }
}

impl Sub for Point {
    type Output = Vector;
    fn sub(self, p: Point) -> Vector {
        Vector { x: self.x - p.x, y: self.y - p.y }
    }
}

impl Add for Vector {
    type Output = Vector;
    fn add(self, v: Vector) -> Vector {
        Vector { x: self.x + v.x, y: self.y + v.y }
    }
}

impl Sub for Vector {
    type Output = Vector;
    fn sub(self, v: Vector) -> Vector {
        Vector { x: self.x - v.x, y: self.y - v.y }
    }
}

impl Neg for Vector {
    type Output = Vector;
    fn neg(self) -> Vector {
        Vector { x: -self.x, y: -self.y }
    }
}

impl Mul<f64> for Vector {
    type Output = Vector;
    fn mul(self, s: f64) -> Vector {
        Vector { x: self.x * s, y: self.y * s }
    }
}

impl Mul<Vector> for f64 {
    type Output = Vector;
    fn mul(self, v: Vector) -> Vector {
        v * self
    }
}

/// A 2 x 2 matrix, row-major: `m[r][c]` (a Jacobian `[[dx'/dx, dx'/dy], [dy'/dx, dy'/dy]]`,
/// or the linear part of an affine map).
pub type Mat2 = [[f64; 2]; 2];

/// `m v`.
pub fn mat_vec(m: &Mat2, v: Vector) -> Vector {
    Vector::new(m[0][0] * v.x + m[0][1] * v.y, m[1][0] * v.x + m[1][1] * v.y)
}

/// `det m`.
pub fn det(m: &Mat2) -> f64 {
    m[0][0] * m[1][1] - m[0][1] * m[1][0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_and_vectors_keep_their_roles() {
        let (p, q) = (Point::new(1.0, 2.0), Point::new(4.0, 6.0));
        let v = q - p;
        assert_eq!(v, Vector::new(3.0, 4.0));
        assert_eq!(p + v, q);
        assert_eq!(q - v, p);
        assert_eq!(p.distance(q), 5.0);
        assert_eq!(p.lerp(q, 0.5), Point::new(2.5, 4.0));
        assert_eq!(-v + v, Vector::ZERO);
        assert_eq!(2.0 * v, v * 2.0);
        assert_eq!(v.dot(Vector::new(-4.0, 3.0)), 0.0);
        assert_eq!(Vector::new(1.0, 0.0).cross(Vector::new(0.0, 1.0)), 1.0);
        let mut r = p;
        r += v;
        r -= v;
        assert_eq!(r, p);
        assert!(!Point::new(f64::NAN, 0.0).is_finite());
    }

    #[test]
    fn matrices_act_on_vectors() {
        let m = [[2.0, 1.0], [0.0, 3.0]];
        assert_eq!(mat_vec(&m, Vector::new(1.0, 1.0)), Vector::new(3.0, 3.0));
        assert_eq!(det(&m), 6.0);
    }

    #[test]
    fn arrays_convert_both_ways_and_the_layout_is_two_f64s() {
        assert_eq!(std::mem::size_of::<Point>(), 16);
        assert_eq!(std::mem::align_of::<Point>(), std::mem::align_of::<[f64; 2]>());
        let a = [0.5, -7.25];
        assert_eq!(<[f64; 2]>::from(Point::from(a)), a);
        assert_eq!(Vector::from(a).to_array(), a);
    }
}
