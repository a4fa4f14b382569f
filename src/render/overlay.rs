//! Fit overlays: a frame with the deformed model's outline and the landmarks.
//!
//! Everything is in frame pixels, pixel `(i, j)` centred at `(i, j)` (tiny-skia's pixel
//! centres are at `+0.5`, added here). The outline is the deformed model's silhouette seen
//! from above: the edges between a face turned up (`+z` normal) and a face turned down, and
//! the border edges. Landmarks: the target `t_i` as a red ring, `phi(s_i)` as a green dot,
//! joined by a yellow line (its length is the residual).

use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Stroke, Transform};

/// The silhouette (from `+z`) of a triangle mesh as 2D segments: the border edges (one
/// triangle) and the edges whose triangles do not all face the same way (up or down in the
/// xy projection). Segments come ordered by their vertex pair.
pub fn silhouette(vertices: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<[[f64; 2]; 2]> {
    SilhouetteEdges::new(triangles).segments(vertices)
}

/// The edges of a triangle mesh grouped once, for the [`silhouette`] of many deformations of
/// the same mesh (the editor draws one per drag step): each query then only computes which
/// way the triangles face.
#[derive(Clone, Debug)]
pub struct SilhouetteEdges {
    triangles: Vec<[u32; 3]>,
    /// `(low, high, triangle)` per triangle side, sorted: the sides of one edge are adjacent.
    sides: Vec<(u32, u32, u32)>,
}

impl SilhouetteEdges {
    /// Groups the edges of `triangles`.
    pub fn new(triangles: &[[u32; 3]]) -> SilhouetteEdges {
        let mut sides = Vec::with_capacity(3 * triangles.len());
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                sides.push((a.min(b), a.max(b), t as u32));
            }
        }
        sides.sort_unstable();
        SilhouetteEdges { triangles: triangles.to_vec(), sides }
    }

    /// The silhouette segments for the vertex positions `vertices`.
    pub fn segments(&self, vertices: &[[f64; 3]]) -> Vec<[[f64; 2]; 2]> {
        let up: Vec<bool> = self
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| vertices[i as usize]);
                (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]) > 0.0
            })
            .collect();
        self.sides
            .chunk_by(|x, y| (x.0, x.1) == (y.0, y.1))
            .filter(|e| e.len() == 1 || e.iter().any(|s| up[s.2 as usize] != up[e[0].2 as usize]))
            .map(|e| {
                let (p, q) = (vertices[e[0].0 as usize], vertices[e[0].1 as usize]);
                [[p[0], p[1]], [q[0], q[1]]]
            })
            .collect()
    }
}

/// A landmark in the overlay: where the fit sends its source, and its target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mark {
    /// `phi(s_i)`.
    pub mapped: [f64; 2],
    /// `t_i`.
    pub target: [f64; 2],
}

/// The frame (8-bit gray, `w x h`) in gray with `outline` in cyan and the landmarks.
/// `None` if the size is zero.
pub fn overlay(
    frame: &[u8],
    w: u32,
    h: u32,
    outline: &[[[f64; 2]; 2]],
    marks: &[Mark],
) -> Option<Pixmap> {
    let mut pm = Pixmap::new(w, h)?;
    for (d, &g) in pm.pixels_mut().iter_mut().zip(frame) {
        *d = tiny_skia::ColorU8::from_rgba(g, g, g, 255).premultiply();
    }
    let paint = |r: u8, g: u8, b: u8| {
        let mut p = Paint::default();
        p.set_color(Color::from_rgba8(r, g, b, 255));
        p.anti_alias = true;
        p
    };
    if !outline.is_empty() {
        let mut pb = PathBuilder::new();
        for [a, b] in outline {
            pb.move_to(a[0] as f32 + 0.5, a[1] as f32 + 0.5);
            pb.line_to(b[0] as f32 + 0.5, b[1] as f32 + 0.5);
        }
        if let Some(path) = pb.finish() {
            let stroke = Stroke { width: 1.2, ..Stroke::default() };
            pm.stroke_path(&path, &paint(0, 220, 255), &stroke, Transform::identity(), None);
        }
    }
    for m in marks {
        let (mx, my) = (m.mapped[0] as f32 + 0.5, m.mapped[1] as f32 + 0.5);
        let (tx, ty) = (m.target[0] as f32 + 0.5, m.target[1] as f32 + 0.5);
        let mut pb = PathBuilder::new();
        pb.move_to(mx, my);
        pb.line_to(tx, ty);
        if let Some(p) = pb.finish() {
            let stroke = Stroke { width: 1.5, ..Stroke::default() };
            pm.stroke_path(&p, &paint(255, 220, 0), &stroke, Transform::identity(), None);
        }
        if let Some(c) = PathBuilder::from_circle(tx, ty, 4.5) {
            let stroke = Stroke { width: 1.5, ..Stroke::default() };
            pm.stroke_path(&c, &paint(255, 40, 40), &stroke, Transform::identity(), None);
        }
        if let Some(c) = PathBuilder::from_circle(mx, my, 2.2) {
            pm.fill_path(&c, &paint(40, 230, 40), FillRule::Winding, Transform::identity(), None);
        }
    }
    Some(pm)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn silhouette_of_a_closed_box_is_its_outline_from_above() {
        // A flat closed "pillow": two triangles up (z = 1) and two down (z = 0), same square.
        let v = [[0.0, 0.0, 1.0], [4.0, 0.0, 1.0], [4.0, 4.0, 1.0], [0.0, 4.0, 1.0]];
        let up = [[0, 1, 2], [0, 2, 3]];
        // Same vertices, reversed orientation (facing down): shares every edge.
        let down = [[0, 2, 1], [0, 3, 2]];
        let tris: Vec<[u32; 3]> = up.iter().chain(&down).copied().collect();
        let s = silhouette(&v, &tris);
        // The four sides and the diagonal (whose two up faces meet two down faces).
        assert_eq!(s.len(), 5, "{s:?}");
        let open = silhouette(&v, &up);
        assert_eq!(open.len(), 4, "border edges of an open square");
    }

    #[test]
    fn overlay_draws_marks_where_they_are() {
        let frame = vec![0u8; 40 * 30];
        let pm =
            overlay(&frame, 40, 30, &[], &[Mark { mapped: [10.0, 10.0], target: [30.0, 20.0] }])
                .unwrap();
        let px = |x: u32, y: u32| pm.pixel(x, y).unwrap();
        assert!(px(10, 10).green() > 150 && px(10, 10).red() < 100, "green dot at phi(s)");
        assert!(px(34, 20).red() > 150, "red ring around the target");
        assert_eq!(px(2, 28).red(), 0, "background untouched");
    }
}
