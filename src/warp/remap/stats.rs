//! What a preimage computation found: pixels per path of the inverse map, the largest error
//! bound, the folds (see [`super`] for the paths).

/// What a preimage computation found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RemapStats {
    /// Output pixels visited.
    pub pixels: usize,
    /// Pixels without a preimage (outside the deformed mesh).
    pub outside: usize,
    /// Largest error bound over the pixels that have a preimage (pixels).
    pub max_error_bound: f64,
    /// Pixels solved one by one by Newton (near the border of the deformed mesh, where the
    /// smallest pieces miss the bound, and in strongly compressed pieces).
    pub newton_solves: usize,
    /// Of [`RemapStats::newton_solves`], those whose Newton iteration started from the
    /// affine inverse of the piece that needed it (the others needed the neighbour's
    /// preimage or the forward samples as seeds).
    pub newton_seeded: usize,
    /// Of [`RemapStats::newton_seeded`], the pixels of pieces where `phi` compresses so
    /// strongly that interpolation would cost several forward evaluations per pixel.
    pub newton_compressed: usize,
    /// Of [`RemapStats::newton_seeded`], the pixels in the thin gaps between neighbouring
    /// pieces of different sizes (T-junctions of the lattice refinement).
    pub newton_gaps: usize,
    /// Pixels that Newton tried and found no preimage for (counted in
    /// [`RemapStats::outside`] too).
    pub newton_failed: usize,
    /// Pixels filled from the forward lattice under a proven bound.
    pub interpolated: usize,
    /// Pixels filled from pieces where `phi` folds (orientation reversed); they are not
    /// counted in `max_error_bound`.
    pub folded: usize,
    /// Output box `[x0, y0, x1, y1]` (pixels, inclusive) of the folded pieces drawn.
    pub fold_box: Option<[u32; 4]>,
}

impl RemapStats {
    /// Adds another band's figures.
    pub fn merge(&mut self, o: &RemapStats) {
        self.pixels += o.pixels;
        self.outside += o.outside;
        self.max_error_bound = self.max_error_bound.max(o.max_error_bound);
        self.newton_solves += o.newton_solves;
        self.newton_seeded += o.newton_seeded;
        self.newton_gaps += o.newton_gaps;
        self.newton_compressed += o.newton_compressed;
        self.newton_failed += o.newton_failed;
        self.interpolated += o.interpolated;
        self.folded += o.folded;
        self.fold_box = match (self.fold_box, o.fold_box) {
            (Some(a), Some(b)) => {
                Some([a[0].min(b[0]), a[1].min(b[1]), a[2].max(b[2]), a[3].max(b[3])])
            }
            (a, b) => a.or(b),
        };
    }

    /// One line: how many pixels took each path of the inverse map.
    pub fn paths_line(&self) -> String {
        format!(
            "{} pixels: {} interpolated from certified pieces, {} drawn from folded pieces, {} by Newton ({} seeded from the piece's affine inverse, of them {} in gaps between pieces and {} where phi compresses strongly, {} from other seeds), {} outside ({} after a failed Newton search)",
            self.pixels,
            self.interpolated - self.folded.min(self.interpolated),
            self.folded,
            self.newton_solves,
            self.newton_seeded,
            self.newton_gaps,
            self.newton_compressed,
            self.newton_solves - self.newton_seeded,
            self.outside,
            self.newton_failed
        )
    }
}
