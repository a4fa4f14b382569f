//! The fast preview path of a morph ([`Morph::preview`]): `A` as a colour mesh whose
//! vertices move linearly in the shape weight (`v + s (phi_ab(v) - v)`), with vertex colours
//! blended towards `B`'s, rasterized with tiny-skia.

use super::*;

impl Morph {
    /// The colour mesh of `A` (one vertex per `step` pixels) with, per vertex, `A`'s colour,
    /// `B`'s colour at `phi_{A->B}(v) = S^-1(phi_ab(v))` (`A`'s where that is outside `B`) and
    /// `phi_ab(v)` itself. Vertices outside `phi_{A->B}`'s domain are dropped with their triangles.
    pub fn preview(&self, step: u32) -> Result<Preview, MorphError> {
        let full = ColorMesh::from_image(&self.a, step, ColorMode::PerVertex)?;
        let mut q = vec![None; full.vertices.len()];
        self.phi_ab.eval_many(&full.vertices, &mut q);
        let Colors::PerVertex(all_colors) = &full.colors else { unreachable!("per-vertex mode") };
        // Keep the vertices with an image (and the triangles of kept vertices), in order.
        let mut remap = vec![u32::MAX; q.len()];
        let (mut base, mut targets, mut ca) = (Vec::new(), Vec::new(), Vec::new());
        for (i, qi) in q.iter().enumerate() {
            if let Some(p) = qi {
                remap[i] = base.len() as u32;
                base.push(full.vertices[i]);
                targets.push(*p);
                ca.push(all_colors[i]);
            }
        }
        let triangles: Vec<[u32; 3]> = full
            .triangles
            .iter()
            .map(|t| t.map(|i| remap[i as usize]))
            .filter(|t| !t.contains(&u32::MAX))
            .collect();
        let b = self.b.to_rgba8();
        let src = Source { data: b.as_raw(), w: b.width() as usize, h: b.height() as usize, nc: 4 };
        let (bw, bh) = (f64::from(b.width() - 1), f64::from(b.height() - 1));
        let cb = targets
            .iter()
            .zip(&ca)
            .map(|(p, a)| {
                let p = &self.sim.inverse(*p);
                if p[0] >= 0.0 && p[1] >= 0.0 && p[0] <= bw && p[1] <= bh {
                    let mut px = [0u8; 4];
                    src.sample_into(*p, Interp::Bilinear, &mut px);
                    px
                } else {
                    *a
                }
            })
            .collect();
        let mesh = ColorMesh { vertices: base, triangles, colors: Colors::PerVertex(Vec::new()) };
        Ok(Preview { colors_a: ca, colors_b: cb, targets, mesh })
    }

    /// The preview frame at `t`: the colour mesh moved by `phi_{A->t}`, colours blended,
    /// on `background` (straight RGBA8).
    ///
    /// By linearity (module docs) `phi_{A->t}(v) = v + s (phi_{A->B}(v) - v)`, so a frame
    /// costs one multiply-add per vertex and the rasterization; no spline is evaluated. The
    /// positions agree with evaluating the exact blend to within `f64` rounding.
    pub fn preview_frame(
        &self,
        pv: &Preview,
        t: f64,
        background: [u8; 4],
    ) -> Result<Pixmap, MorphError> {
        self.preview_frame_exact(pv, &exact(t)?, background)
    }

    /// [`Morph::preview_frame`] at an exact `t`.
    pub fn preview_frame_exact(
        &self,
        pv: &Preview,
        t: &Rat,
        background: [u8; 4],
    ) -> Result<Pixmap, MorphError> {
        let (_, c) = self.weights(rat_to_f64(t))?;
        let s = rat_to_f64(&self.opts.shape.at_exact(t));
        if !s.is_finite() {
            return Err(MorphError::Schedule(rat_to_f64(t)));
        }
        let c = c as f32;
        let colors = pv
            .colors_a
            .iter()
            .zip(&pv.colors_b)
            .map(|(a, b)| {
                [0, 1, 2, 3]
                    .map(|k| u8::from_f32((1.0 - c) * f32::from(a[k]) + c * f32::from(b[k])))
            })
            .collect();
        let vertices = pv
            .mesh
            .vertices
            .iter()
            .zip(&pv.targets)
            .map(|(v, q)| [v[0] + s * (q[0] - v[0]), v[1] + s * (q[1] - v[1])])
            .collect();
        let moved = ColorMesh {
            vertices,
            triangles: pv.mesh.triangles.clone(),
            colors: Colors::PerVertex(colors),
        };
        Ok(rasterize(&moved, self.a.width(), self.a.height(), Some(background))?)
    }
}

/// `A`'s colour mesh with both colour sets and the vertices' images ([`Morph::preview`]).
#[derive(Clone, Debug)]
pub struct Preview {
    pub(super) mesh: ColorMesh,
    pub(super) colors_a: Vec<[u8; 4]>,
    pub(super) colors_b: Vec<[u8; 4]>,
    pub(super) targets: Vec<[f64; 2]>,
}

impl Preview {
    /// Number of vertices and triangles of the preview mesh.
    pub fn size(&self) -> (usize, usize) {
        (self.mesh.vertices.len(), self.mesh.triangles.len())
    }
}
