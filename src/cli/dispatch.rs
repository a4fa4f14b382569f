//! What each subcommand runs: the `run` of every argument struct ([`super::args`],
//! [`super::fit_args`]), calling the command's file. The argument structs stay plain data,
//! so the command files can take them without a loop of imports.

use super::args::{BindCli, EditCli, EditorCli, FieldCli, MeshCli, MorphCli, RenderCli, WarpCli};
use super::fit_args::FitCli;
use super::{editor_cmd, fit_batch, fit_cmd, model_cmd, morph_cmd, spline_cmds, warp_cmd};

impl MeshCli {
    /// Runs `trimorph mesh`.
    pub fn run(&self) -> anyhow::Result<()> {
        spline_cmds::mesh(self)
    }
}

impl EditCli {
    /// Runs `trimorph edit`.
    pub fn run(&self) -> anyhow::Result<()> {
        let bounded = if self.unbounded { None } else { Some(self.bounded_bits) };
        spline_cmds::edit(&self.deformation, &self.script, &self.output, bounded)
    }
}

impl RenderCli {
    /// Runs `trimorph render` (through a 2.5D deformation with --model).
    pub fn run(&self) -> anyhow::Result<()> {
        let bg = self.background.as_deref();
        let (def, out, size) = (&self.deformation, &self.output, self.size);
        match &self.model {
            Some(m) => self.marks.refuse_with_model().and_then(|()| {
                let up = self.up.resolve(m)?;
                model_cmd::render_model(def, m, out, bg, self.view, size, up)
            }),
            None => spline_cmds::render(def, out, bg, self.show, size, &self.marks),
        }
    }
}

impl BindCli {
    /// Runs `trimorph model bind`.
    pub fn run(self) -> anyhow::Result<()> {
        let up = self.extra.up.resolve(&self.model)?;
        model_cmd::bind_cmd(&crate::jobs::model::BindOptions {
            model: self.model,
            mesh: self.mesh,
            auto: self.auto,
            grid: self.grid,
            margin: self.margin,
            range: self.range,
            degree: self.degree,
            output: self.output,
            up,
            snap: self.extra.snap,
        })
    }
}

impl WarpCli {
    /// Runs `trimorph warp`.
    pub fn run(&self) -> anyhow::Result<()> {
        warp_cmd::run(self)
    }
}

impl MorphCli {
    /// Runs `trimorph morph`.
    pub fn run(&self) -> anyhow::Result<()> {
        morph_cmd::run(self)
    }
}

impl EditorCli {
    /// Runs `trimorph editor`.
    pub fn run(&self) -> anyhow::Result<()> {
        let start = crate::server::start::StartOptions {
            deformation: self.deformation.clone(),
            model: self.model.clone(),
            image: self.image.clone().or_else(|| self.moving.clone()),
            fixed: self.fixed.clone(),
        };
        editor_cmd::run(&start, self.port)
    }
}

impl FieldCli {
    /// Runs `trimorph field`.
    pub fn run(&self) -> anyhow::Result<()> {
        let opts = crate::jobs::field::FieldOptions {
            output: self.output.clone(),
            inverse: self.inverse,
            both: self.both,
            jacobian: self.jacobian.clone(),
            placement: crate::jobs::field::PlacementParts {
                spacing: self.spacing,
                origin: self.origin,
                unit: self.unit.clone(),
            },
        };
        warp_cmd::field(&self.deformation, &opts, self.size)
    }
}

impl FitCli {
    /// Runs `trimorph fit`: one fit ([`fit_cmd::run_single`]) or a sequence
    /// ([`fit_batch::run`]), by which of DEF, --size and --model/--frames are given.
    pub fn run(self) -> anyhow::Result<()> {
        use crate::jobs::sequence::SceneSource;
        match (&self.deformation, &self.model, &self.frames, self.size) {
            (d, None, None, size) if d.is_some() != size.is_some() => fit_cmd::run_single(&self),
            // A sequence: a 2.5D scene, any 2D deformation, or a 2D scene over the frame.
            (None, Some(scene), Some(frames), None) | (Some(scene), None, Some(frames), None) => {
                fit_batch::run(&self, SceneSource::File(scene.clone()), frames)
            }
            (None, None, Some(frames), Some(size)) => {
                let adapt = self.adapt_options();
                fit_batch::run(&self, SceneSource::Landmarks { size, adapt, degree: 5 }, frames)
            }
            _ => Err(anyhow::anyhow!(
                "give DEF.json (one fit), or --size W,H instead of DEF (one fit over a mesh adapted to the landmarks); for a sequence, --frames with one of --model SCENE.json, DEF.json or --size W,H"
            )),
        }
    }
}
