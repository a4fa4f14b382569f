//! Colored triangle meshes: an image as a fine mesh of colored triangles in the plane, moved
//! through a deformation vertex by vertex.
//!
//! **Coordinates.** Vertices are in pixel coordinates, like the rest of [`crate::warp`]:
//! x to the right, y down, pixel `(i, j)` centred at `(i, j)`. [`ColorMesh::from_image`] puts
//! the vertices on the lattice of pixel centres, so the mesh covers `[0, w - 1] x [0, h - 1]`
//! (centre to centre, half a pixel less than the image on each side).
//!
//! **Which way the map runs.** [`ColorMesh::deform`] moves every vertex *forward*,
//! `v -> phi(v)`, and keeps the triangles and their colors: a feature at `p` lands near
//! `phi(p)`, exactly at `phi(v)` for a vertex `v`. Inside a triangle the result is the affine
//! interpolation of the moved corners, so it approximates the smooth `phi` to within the
//! usual `O(h^2 |D^2 phi|)` for triangles of size `h` (use a fine mesh for strong bends).
//! Nothing is inverted, unlike [`crate::warp::warp_image`], which computes `phi^-1` per pixel.
//!
//! **Colors** are straight (not premultiplied) RGBA8, one per vertex ([`Colors::PerVertex`],
//! interpolated barycentrically when drawn) or one per triangle ([`Colors::PerTriangle`], flat).
//! This is a preview path: every image type is converted to RGBA8 first (16-bit and float
//! samples are scaled to 8 bits).

use crate::spline::Spline;
use image::{DynamicImage, RgbaImage};
use rayon::prelude::*;

/// Most triangles [`ColorMesh::from_image`] makes (about 1.2 GB of mesh at 24 bytes each).
pub const MAX_TRIANGLES: u64 = 50_000_000;

/// Straight RGBA8 colors of a [`ColorMesh`].
#[derive(Clone, Debug, PartialEq)]
pub enum Colors {
    /// One color per vertex, interpolated barycentrically inside each triangle.
    PerVertex(Vec<[u8; 4]>),
    /// One flat color per triangle.
    PerTriangle(Vec<[u8; 4]>),
}

/// How [`ColorMesh::from_image`] colors the mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorMode {
    /// Each vertex takes the pixel it sits on.
    PerVertex,
    /// Each triangle takes the mean color of the pixels whose centres lie in it.
    Flat,
}

/// A triangle mesh in the plane with colors (see the module docs for the conventions).
#[derive(Clone, Debug, PartialEq)]
pub struct ColorMesh {
    /// Vertex positions `(x, y)` in pixel coordinates.
    pub vertices: Vec<[f64; 2]>,
    /// Triangles as vertex indices; orientation is free (both are drawn).
    pub triangles: Vec<[u32; 3]>,
    /// Colors per vertex or per triangle.
    pub colors: Colors,
}

/// Errors of colored meshes: building, checking and drawing them (the file errors are
/// [`crate::io::colormesh::MeshFileError`]).
#[derive(Debug, thiserror::Error)]
pub enum ColorMeshError {
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle}: vertex index {index} out of range ({vertices} vertices)")]
    Index {
        /// The triangle.
        triangle: usize,
        /// The bad index.
        index: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// A vertex has a NaN or infinite coordinate.
    #[error("vertex {vertex}: coordinates ({x}, {y}) are not finite")]
    NonFinite {
        /// The vertex.
        vertex: usize,
        /// Its x.
        x: f64,
        /// Its y.
        y: f64,
    },
    /// The number of colors does not match the number of vertices or triangles.
    #[error("{found} colors for {expected} {kind}s (one per {kind} needed)")]
    ColorCount {
        /// `vertex` or `triangle`.
        kind: &'static str,
        /// Vertices or triangles.
        expected: usize,
        /// Colors.
        found: usize,
    },
    /// The image is too small to make triangles of.
    #[error("a {width}x{height} image has no triangles (at least 2x2 pixels needed)")]
    ImageSize {
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
    /// The lattice step is 0.
    #[error("the mesh step must be at least 1 pixel")]
    Step,
    /// The image at this step would give too many triangles.
    #[error("a {width}x{height} image at step {step} gives {triangles} triangles (at most {MAX_TRIANGLES}; use a larger step)")]
    TooLarge {
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// The step.
        step: u32,
        /// Triangles it would give.
        triangles: u64,
    },
    /// The canvas size is zero or too large for a pixmap.
    #[error("invalid canvas size {width}x{height}")]
    CanvasSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
}

/// Lattice coordinates `0, step, 2 step, ...` and always `n - 1` last.
fn lattice(n: u32, step: u32) -> Vec<u32> {
    let mut v: Vec<u32> = (0..n).step_by(step as usize).collect();
    if v.last() != Some(&(n - 1)) {
        v.push(n - 1);
    }
    v
}

/// Checks the size before any pixel is touched; returns the lattice columns and rows.
fn check_size(width: u32, height: u32, step: u32) -> Result<(Vec<u32>, Vec<u32>), ColorMeshError> {
    if step == 0 {
        return Err(ColorMeshError::Step);
    }
    if width < 2 || height < 2 {
        return Err(ColorMeshError::ImageSize { width, height });
    }
    let cells = |n: u32| u64::from((n - 1).div_ceil(step));
    let triangles = 2 * cells(width) * cells(height);
    if triangles > MAX_TRIANGLES {
        return Err(ColorMeshError::TooLarge { width, height, step, triangles });
    }
    Ok((lattice(width, step), lattice(height, step)))
}

/// Straight mean of pixels, with RGB weighted by alpha (so transparent pixels do not tint).
#[derive(Clone, Copy, Default)]
struct Mean {
    rgb_a: [u64; 3],
    rgb: [u64; 3],
    a: u64,
    n: u64,
}

impl Mean {
    fn add(&mut self, p: [u8; 4]) {
        let a = u64::from(p[3]);
        for c in 0..3 {
            self.rgb_a[c] += u64::from(p[c]) * a;
            self.rgb[c] += u64::from(p[c]);
        }
        self.a += a;
        self.n += 1;
    }

    fn color(&self) -> [u8; 4] {
        let div = |s: u64, d: u64| ((s + d / 2) / d.max(1)).min(255) as u8;
        let rgb = |c: usize| {
            if self.a > 0 {
                div(self.rgb_a[c], self.a)
            } else {
                div(self.rgb[c], self.n)
            }
        };
        [rgb(0), rgb(1), rgb(2), div(self.a, self.n)]
    }
}

impl ColorMesh {
    /// Checks that every index is in range, every coordinate finite and that there is one
    /// color per vertex (or per triangle). Errors name the first bad element.
    pub fn validate(&self) -> Result<(), ColorMeshError> {
        let nv = self.vertices.len();
        for (vertex, &[x, y]) in self.vertices.iter().enumerate() {
            if !(x.is_finite() && y.is_finite()) {
                return Err(ColorMeshError::NonFinite { vertex, x, y });
            }
        }
        for (triangle, t) in self.triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= nv) {
                return Err(ColorMeshError::Index { triangle, index, vertices: nv });
            }
        }
        let (kind, expected, found) = match &self.colors {
            Colors::PerVertex(c) => ("vertex", nv, c.len()),
            Colors::PerTriangle(c) => ("triangle", self.triangles.len(), c.len()),
        };
        if expected != found {
            return Err(ColorMeshError::ColorCount { kind, expected, found });
        }
        Ok(())
    }

    /// The mesh of an image (converted to RGBA8 first: this preview path is 8-bit).
    ///
    /// Vertices sit on pixel centres `(x, y)` with `x` in `0, step, 2 step, ...` and `w - 1`
    /// always last (likewise `y`), numbered row by row (`vertex = row * columns + column`).
    /// Each lattice cell with corners `a = (x0, y0)`, `b = (x1, y0)`, `c = (x0, y1)`,
    /// `d = (x1, y1)` gives the triangles `[a, b, d]` and `[a, d, c]`, cell by cell, row by row.
    ///
    /// * [`ColorMode::PerVertex`]: vertex color = the pixel at the vertex.
    /// * [`ColorMode::Flat`]: triangle color = mean of the pixels whose centres lie in the
    ///   closed triangle (pixels on the diagonal count for both halves; the three corner pixels
    ///   always count). RGB is averaged weighted by alpha, alpha plainly.
    ///
    /// Errors: step 0, an image smaller than 2x2, or more than [`MAX_TRIANGLES`] triangles
    /// (checked before any allocation).
    pub fn from_image(
        img: &DynamicImage,
        step: u32,
        mode: ColorMode,
    ) -> Result<ColorMesh, ColorMeshError> {
        let (xs, ys) = check_size(img.width(), img.height(), step)?;
        let rgba = img.to_rgba8();
        let nx = xs.len();
        let vertices: Vec<[f64; 2]> = ys
            .iter()
            .flat_map(|&y| xs.iter().map(move |&x| [f64::from(x), f64::from(y)]))
            .collect();
        let mut triangles = Vec::with_capacity(2 * (nx - 1) * (ys.len() - 1));
        for r in 0..ys.len() - 1 {
            for c in 0..nx - 1 {
                let a = (r * nx + c) as u32;
                let (b, cc, d) = (a + 1, a + nx as u32, a + nx as u32 + 1);
                triangles.push([a, b, d]);
                triangles.push([a, d, cc]);
            }
        }
        let colors = match mode {
            ColorMode::PerVertex => {
                let rgba = &rgba;
                let at = |y: u32| xs.iter().map(move |&x| rgba.get_pixel(x, y).0);
                Colors::PerVertex(ys.iter().flat_map(|&y| at(y)).collect())
            }
            ColorMode::Flat => Colors::PerTriangle(flat_colors(&rgba, &xs, &ys)),
        };
        Ok(ColorMesh { vertices, triangles, colors })
    }

    /// Moves every vertex through the spline, `v -> phi(v)` (see the module docs).
    ///
    /// Vertices outside the spline's mesh have no image: they are removed, and so is every
    /// triangle using one (or, in an invalid mesh, an index out of range). The kept vertices
    /// and triangles keep their relative order and their colors, and vertices inside whose
    /// triangles were all dropped are kept. Returns the new mesh and the number of dropped
    /// triangles. A triangle color missing in an invalid mesh becomes transparent.
    pub fn deform(&self, s: &Spline) -> (ColorMesh, usize) {
        let mut out = vec![None; self.vertices.len()];
        s.eval_many(&self.vertices, &mut out);
        let mut remap = vec![u32::MAX; out.len()];
        let mut vertices = Vec::with_capacity(out.len());
        for (i, q) in out.iter().enumerate() {
            if let Some(q) = q {
                remap[i] = vertices.len() as u32;
                vertices.push(*q);
            }
        }
        let mut triangles = Vec::with_capacity(self.triangles.len());
        let mut kept_colors = Vec::new();
        for (k, t) in self.triangles.iter().enumerate() {
            let m = t.map(|i| remap.get(i as usize).copied().unwrap_or(u32::MAX));
            if m.contains(&u32::MAX) {
                continue;
            }
            triangles.push(m);
            if let Colors::PerTriangle(c) = &self.colors {
                kept_colors.push(c.get(k).copied().unwrap_or([0; 4]));
            }
        }
        let dropped = self.triangles.len() - triangles.len();
        let colors = match &self.colors {
            Colors::PerVertex(c) => Colors::PerVertex(
                c.iter().zip(&out).filter(|(_, q)| q.is_some()).map(|(c, _)| *c).collect(),
            ),
            Colors::PerTriangle(_) => Colors::PerTriangle(kept_colors),
        };
        (ColorMesh { vertices, triangles, colors }, dropped)
    }
}

/// Flat colors of the lattice triangles (see [`ColorMesh::from_image`]), cell rows in parallel.
fn flat_colors(img: &RgbaImage, xs: &[u32], ys: &[u32]) -> Vec<[u8; 4]> {
    (0..ys.len() - 1)
        .into_par_iter()
        .flat_map_iter(|r| {
            let (y0, y1) = (ys[r], ys[r + 1]);
            xs.windows(2).flat_map(move |cx| {
                let (x0, x1) = (cx[0], cx[1]);
                let (mut upper, mut lower) = (Mean::default(), Mean::default());
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        // Exact side test of the diagonal a -> d: [a, b, d] holds the pixels
                        // with (y - y0) / (y1 - y0) <= (x - x0) / (x1 - x0), [a, d, c] the others
                        // (both hold those on the diagonal).
                        let lhs = u64::from(y - y0) * u64::from(x1 - x0);
                        let rhs = u64::from(x - x0) * u64::from(y1 - y0);
                        let p = img.get_pixel(x, y).0;
                        if lhs <= rhs {
                            upper.add(p);
                        }
                        if lhs >= rhs {
                            lower.add(p);
                        }
                    }
                }
                [upper.color(), lower.color()]
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::{rat_int, Rat};
    use crate::mesh::{Mesh, MeshOptions};
    use image::Rgba;

    fn image(w: u32, h: u32) -> DynamicImage {
        DynamicImage::ImageRgba8(RgbaImage::from_fn(w, h, |x, y| {
            Rgba([(x * 10) as u8, (y * 20) as u8, (x * y) as u8, 255])
        }))
    }

    #[test]
    fn lattice_keeps_the_last_row_and_column() {
        assert_eq!(lattice(10, 4), vec![0, 4, 8, 9]);
        assert_eq!(lattice(9, 4), vec![0, 4, 8]);
        assert_eq!(lattice(2, 5), vec![0, 1]);
        let m = ColorMesh::from_image(&image(10, 7), 4, ColorMode::PerVertex).unwrap();
        m.validate().unwrap();
        assert_eq!(m.vertices.len(), 4 * 3);
        assert_eq!(m.triangles.len(), 2 * 3 * 2);
        assert_eq!(m.vertices[5], [4.0, 4.0]);
        assert_eq!(m.vertices[11], [9.0, 6.0]);
        // Cell (0, 0): a = 0, b = 1, c = 4, d = 5.
        assert_eq!(&m.triangles[..2], &[[0, 1, 5], [0, 5, 4]]);
        let Colors::PerVertex(c) = &m.colors else { panic!("per vertex") };
        assert_eq!(c[11], [90, 120, 54, 255]);
    }

    #[test]
    fn flat_colors_are_means_of_the_pixels_inside() {
        // 3x3 image, step 2: one cell, the diagonal (0,0)-(2,2) splits it.
        let img = DynamicImage::ImageRgba8(RgbaImage::from_fn(3, 3, |x, y| {
            let v = if x > y {
                90
            } else if x < y {
                30
            } else {
                60
            };
            Rgba([v, 0, 0, 255])
        }));
        let m = ColorMesh::from_image(&img, 2, ColorMode::Flat).unwrap();
        let Colors::PerTriangle(c) = &m.colors else { panic!("flat") };
        // Upper [a, b, d]: 3 pixels of 90 and 3 of 60 on the diagonal; lower: 30s and 60s.
        assert_eq!(c, &vec![[75, 0, 0, 255], [45, 0, 0, 255]]);
        // Transparent pixels do not tint the mean color.
        let img = DynamicImage::ImageRgba8(RgbaImage::from_fn(2, 2, |x, _| {
            if x == 0 {
                Rgba([200, 100, 0, 255])
            } else {
                Rgba([0, 0, 255, 0])
            }
        }));
        let m = ColorMesh::from_image(&img, 1, ColorMode::Flat).unwrap();
        let Colors::PerTriangle(c) = &m.colors else { panic!("flat") };
        assert_eq!(c[0], [200, 100, 0, 85]);
    }

    #[test]
    fn bad_sizes_and_steps_are_rejected() {
        let err = |w, h, s| check_size(w, h, s).unwrap_err();
        assert!(matches!(err(10, 10, 0), ColorMeshError::Step));
        assert!(matches!(err(0, 10, 1), ColorMeshError::ImageSize { .. }));
        assert!(matches!(err(1, 10, 1), ColorMeshError::ImageSize { .. }));
        let e = err(100_000, 100_000, 1);
        assert!(
            matches!(e, ColorMeshError::TooLarge { triangles, .. } if triangles > MAX_TRIANGLES)
        );
        assert!(check_size(100_000, 100_000, 20).is_ok());
        let img = DynamicImage::ImageRgb8(image::RgbImage::new(0, 0));
        assert!(ColorMesh::from_image(&img, 1, ColorMode::Flat).is_err());
    }

    #[test]
    fn validate_names_the_bad_element() {
        let m = ColorMesh::from_image(&image(4, 4), 1, ColorMode::PerVertex).unwrap();
        let mut bad = m.clone();
        bad.triangles[7][2] = 16;
        let e = bad.validate().unwrap_err();
        assert!(matches!(e, ColorMeshError::Index { triangle: 7, index: 16, vertices: 16 }));
        let mut bad = m.clone();
        bad.vertices[3][1] = f64::NAN;
        assert!(matches!(bad.validate().unwrap_err(), ColorMeshError::NonFinite { vertex: 3, .. }));
        let mut bad = m.clone();
        bad.colors = Colors::PerTriangle(vec![[0; 4]; 3]);
        let e = bad.validate().unwrap_err().to_string();
        assert_eq!(e, "3 colors for 18 triangles (one per triangle needed)");
    }

    fn spline(w: f64, h: f64, dx: i64, dy: i64) -> Spline {
        let mesh = Mesh::grid(4, 3, w, h, MeshOptions::default()).unwrap();
        let id = Spline::identity(mesh.clone(), 5).unwrap();
        let pts: Vec<Vec<Rat>> =
            id.points().iter().map(|p| vec![&p[0] + rat_int(dx), &p[1] + rat_int(dy)]).collect();
        Spline::from_points(mesh, 5, pts, None).unwrap()
    }

    #[test]
    fn deform_moves_vertices_and_keeps_colors() {
        let m = ColorMesh::from_image(&image(12, 9), 2, ColorMode::Flat).unwrap();
        let (d, dropped) = m.deform(&spline(11.0, 8.0, 3, -2));
        assert_eq!(dropped, 0);
        assert_eq!((&d.triangles, &d.colors), (&m.triangles, &m.colors));
        for (p, q) in m.vertices.iter().zip(&d.vertices) {
            assert!((q[0] - p[0] - 3.0).abs() < 1e-9 && (q[1] - p[1] + 2.0).abs() < 1e-9);
        }
    }

    #[test]
    fn deform_drops_triangles_outside_and_compacts() {
        // The spline covers [0, 6] x [0, 8]: lattice columns 0..=6 stay, 7 and 8 leave.
        let img = image(9, 9);
        let s = spline(6.0, 8.0, 0, 0);
        let m = ColorMesh::from_image(&img, 1, ColorMode::PerVertex).unwrap();
        let (d, dropped) = m.deform(&s);
        d.validate().unwrap();
        assert_eq!(d.vertices.len(), 7 * 9);
        assert_eq!(d.triangles.len(), 2 * 6 * 8);
        assert_eq!(dropped, 2 * 8 * 8 - 2 * 6 * 8);
        let (Colors::PerVertex(c), Colors::PerVertex(c0)) = (&d.colors, &m.colors) else {
            panic!("per vertex")
        };
        for (k, p) in d.vertices.iter().enumerate() {
            let orig = (p[1].round() as usize) * 9 + p[0].round() as usize;
            assert_eq!(c[k], c0[orig], "vertex {k} at {p:?}");
        }
        let m = ColorMesh::from_image(&img, 1, ColorMode::Flat).unwrap();
        let (d, _) = m.deform(&s);
        let (Colors::PerTriangle(c), Colors::PerTriangle(c0)) = (&d.colors, &m.colors) else {
            panic!("flat")
        };
        // Row 0 keeps its first 12 triangles, then row 1 starts at original triangle 16.
        assert_eq!((c[11], c[12]), (c0[11], c0[16]));
        d.validate().unwrap();
    }
}
