//! Drag previews of soft translations ([`Editor::preview_translate`]): the positions of the
//! anchors and derived points are affine in the translation `v` (thesis Alg. 4 with hints
//! `base + theta v`), so a basis `p(v) = p0 + v_x gx + v_y gy` built once per selection
//! makes each call a few multiply-adds per point. The basis comes from ECLES's exact affine
//! map on sessions, from three exact solves on the modular path ([`super::modular`]), or
//! from the select-all solve in determining-set coordinates ([`super::global`]).

use super::{modular, EditError, Editor, Mode};
use crate::exact::rat_to_f64;

impl Editor {
    /// Fast preview of a soft translation by `v` (xy mode, single session): the positions of
    /// the anchors and derived points, in `f64`, without changing the spline. Built once per
    /// selection from ECLES's exact affine map (positions are affine in `v`), then each call
    /// costs a few multiply-adds per point. Certify with [`Editor::translate`] at the end of
    /// the drag. Positions are in the order anchors, then derived.
    pub fn preview_translate(&mut self, v: [f64; 2]) -> Result<Vec<[f64; 2]>, EditError> {
        let sel = self.selection.as_ref().ok_or(EditError::NoSelection)?;
        if sel.plans.len() == 1 && sel.mode == Mode::Xy && sel.preview.is_none() {
            let (plan, a, d, th) =
                (&sel.plans[0], &sel.base_anchors, &sel.base_derived, &sel.theta);
            match modular::preview_basis(plan, a, d, th)? {
                Some(basis) => {
                    self.selection.as_mut().expect("checked above").preview = Some(basis)
                }
                None => self.fall_back_to_sessions()?,
            }
        }
        let sel = self.selection.as_mut().ok_or(EditError::NoSelection)?;
        if let (Some(solve), None) = (&sel.global, &sel.preview) {
            let basis = solve.preview_basis(sel, self.spline.num_points());
            sel.preview = Some(basis);
        }
        if sel.preview.is_none() && (sel.mode != Mode::Xy || sel.sessions.len() != 1) {
            return Err(EditError::Mode(
                "preview works for xy edits without extra constraints".into(),
            ));
        }
        if sel.preview.is_none() {
            // derived(v) = H (base_D + theta v) + J (base_A + v) + c  =  p0 + v_x gx + v_y gy.
            let map = sel.sessions[0].affine_map(None)?.to_f64();
            let nd = sel.derived.len();
            let base_a: Vec<f64> = sel.base_anchors.iter().flatten().map(rat_to_f64).collect();
            let base_d: Vec<f64> = sel.base_derived.iter().flatten().map(rat_to_f64).collect();
            let eval = |dv: [f64; 2], shift: bool| -> Vec<f64> {
                let anchors: Vec<f64> = base_a
                    .chunks(2)
                    .flat_map(|a| if shift { [dv[0], dv[1]] } else { [a[0] + dv[0], a[1] + dv[1]] })
                    .collect();
                let hints: Vec<f64> = base_d
                    .chunks(2)
                    .zip(&sel.theta)
                    .flat_map(|(p, th)| {
                        if shift {
                            [th * dv[0], th * dv[1]]
                        } else {
                            [p[0] + th * dv[0], p[1] + th * dv[1]]
                        }
                    })
                    .collect();
                let mut out = vec![0.0; nd * 2];
                if shift {
                    // Linear part only: evaluate the map without its constant term.
                    let lin = crate::ecles::AffineMapF64 { c: vec![0.0; nd * 2], ..map.clone() };
                    lin.eval_into(&anchors, &hints, &mut out);
                } else {
                    map.eval_into(&anchors, &hints, &mut out);
                }
                out
            };
            let p0 = eval([0.0, 0.0], false);
            let gx = eval([1.0, 0.0], true);
            let gy = eval([0.0, 1.0], true);
            sel.preview = Some((p0, gx, gy));
        }
        let (p0, gx, gy) =
            sel.preview.as_ref().expect("the preview is built just above when missing");
        let mut out: Vec<[f64; 2]> = sel
            .base_anchors
            .iter()
            .map(|a| [rat_to_f64(&a[0]) + v[0], rat_to_f64(&a[1]) + v[1]])
            .collect();
        out.extend((0..sel.derived.len()).map(|k| {
            let i = 2 * k;
            [p0[i] + v[0] * gx[i] + v[1] * gy[i], p0[i + 1] + v[0] * gx[i + 1] + v[1] * gy[i + 1]]
        }));
        Ok(out)
    }
}
