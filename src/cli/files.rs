//! Every command's files by role, checked before the command runs: no output may be one
//! of its inputs or another of its outputs ([`crate::io::clash`]). Folder outputs list the
//! files the command writes into them (a morph's frames, animations, sheet and maps).

use super::{BenchCommand, Command, ModelCommand};
use crate::io::clash::CommandFiles;
use std::path::Path;

/// The files of a command line (empty for commands that write only into a folder of their
/// own, or not at all: `demo`, `model worm`, `bench`, `check`, `editor`).
pub(super) fn files(cmd: &Command) -> CommandFiles {
    let f = CommandFiles::new();
    match cmd {
        Command::Solve { system, output } => {
            f.input("SYSTEM", o(system)).output("--output", output.as_deref())
        }
        Command::Mesh(a) => f
            .input("--points", a.points.as_deref())
            .input("--outline", a.outline.as_deref())
            .input("--obj", a.obj.as_deref())
            .input("--landmarks", a.landmarks.as_deref())
            .output("--output", o(&a.output)),
        Command::Edit(a) => f
            .input("DEFORMATION", o(&a.deformation))
            .input("--script", o(&a.script))
            .output("--output", o(&a.output)),
        Command::Render(a) => f
            .input("DEFORMATION", o(&a.deformation))
            .input("--background", a.background.as_deref())
            .input("--model", a.model.as_deref())
            .input("--landmarks", a.marks.landmarks.as_deref())
            .output("--output", o(&a.output)),
        Command::Model(ModelCommand::Bind(a)) => f
            .input("--model", o(&a.model))
            .input("--mesh", a.mesh.as_deref())
            .output("--output", o(&a.output)),
        Command::Colormesh { image, output, .. } => {
            f.input("IMAGE", o(image)).output("--output", o(output))
        }
        Command::Warp(a) => f
            .input("DEFORMATION", o(&a.deformation))
            .input("--image", a.image.as_deref())
            .input("--points", a.points.as_deref())
            .input("--mesh", a.mesh.as_deref())
            .input("--model", a.model.as_deref())
            .output("--output", o(&a.output)),
        Command::Morph(a) => {
            let mut f = f
                .input("image A", o(&a.a))
                .input("image B", o(&a.b))
                .input("--landmarks", a.landmarks.as_deref())
                .input("--landmarks-src", a.landmarks_src.as_deref())
                .input("--landmarks-dst", a.landmarks_dst.as_deref())
                .input("--phi-ab", a.phi_ab.as_deref())
                .input("--phi-ba", a.phi_ba.as_deref());
            let gif = a.gif.clone().unwrap_or_else(|| a.output.join("morph.gif"));
            let apng = a.apng.clone().unwrap_or_else(|| a.output.join("morph.apng"));
            f = f.output("--gif", Some(&gif)).output("--apng", Some(&apng));
            for name in ["phi_ab.json", "phi_ba.json", "contact-sheet.png"] {
                f = f.output("--output", Some(&a.output.join(name)));
            }
            for k in 0..a.frames.min(crate::jobs::morph::MAX_FRAMES) {
                let name = crate::morph::output::frame_name(k, a.frames);
                f = f.output("--output", Some(&a.output.join(name)));
            }
            f
        }
        Command::Field(a) => f
            .input("DEFORMATION", o(&a.deformation))
            .output("--output", o(&a.output))
            .output("--jacobian", a.jacobian.as_deref()),
        Command::Match(m) => m.files(f),
        Command::Fit(a) => {
            let f = f
                .input("DEFORMATION", a.deformation.as_deref())
                .input("--landmarks", a.landmarks.as_deref())
                .input("--landmarks-src", a.landmarks_src.as_deref())
                .input("--landmarks-dst", a.landmarks_dst.as_deref())
                .input("--model", a.model.as_deref())
                .input("--model-file", a.model_file.as_deref())
                .input("--frames", a.frames.as_deref());
            // With --frames the output is a folder of per-frame files named after the frames.
            if a.frames.is_some() {
                f.output("--report", a.report.as_deref())
            } else {
                f.output("--output", o(&a.output)).output("--report", a.report.as_deref())
            }
        }
        Command::Register(r) => r.files(f),
        Command::Demo { .. }
        | Command::Check { .. }
        | Command::Editor(_)
        | Command::Model(ModelCommand::Worm { .. })
        | Command::Bench { which: BenchCommand::Bitgrowth { .. } } => f,
    }
}

/// `Some(path)` as a `Path`.
fn o(p: &Path) -> Option<&Path> {
    Some(p)
}

#[cfg(test)]
#[path = "files_tests.rs"]
mod tests;
