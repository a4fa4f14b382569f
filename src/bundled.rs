//! Data compiled into the library: the ECLES example problems and the microscope image of
//! `trimorph demo`, a ten-frame fluorescence time-lapse of moving nuclei with hand-made
//! tracks of the nucleus centres (`data/microscopy`), and the bundled 2.5D scene built on
//! them (the demo's, the editor benchmark's, and a ready-made input for library callers).
//!
//! The scene is a PrisMystic deformation (thesis Part III): a worm-like organism model
//! ([`crate::prism::organism::worm`]) in a layer of prisms (`z` in `[-16, 16]`) over an
//! 8 x 8-cell identity mesh of time-lapse frame 0.

use crate::exact::rat_int;
use crate::mesh::{Mesh, MeshError, MeshOptions};
use crate::prism::organism::{worm, WormOptions};
use crate::prism::{identity_layers, Model, PrismError};
use crate::spline::{Spline, SplineError};
use image::DynamicImage;
use std::collections::BTreeMap;

/// The microscope image of the demo (550 x 660 px, PNG).
pub const CELL_PNG: &[u8] = include_bytes!("../data/microscopy/cell.png");

/// The time-lapse frames (511 x 511 px, PNG), in order.
pub const TIMELAPSE_FRAMES: [&[u8]; 10] = [
    include_bytes!("../data/microscopy/timelapse/frame_00.png"),
    include_bytes!("../data/microscopy/timelapse/frame_01.png"),
    include_bytes!("../data/microscopy/timelapse/frame_02.png"),
    include_bytes!("../data/microscopy/timelapse/frame_03.png"),
    include_bytes!("../data/microscopy/timelapse/frame_04.png"),
    include_bytes!("../data/microscopy/timelapse/frame_05.png"),
    include_bytes!("../data/microscopy/timelapse/frame_06.png"),
    include_bytes!("../data/microscopy/timelapse/frame_07.png"),
    include_bytes!("../data/microscopy/timelapse/frame_08.png"),
    include_bytes!("../data/microscopy/timelapse/frame_09.png"),
];

/// The tracks of the nucleus centres, CSV `track_id,frame,y,x` with a header line.
pub const TIMELAPSE_TRACKS: &str = include_str!("../data/microscopy/timelapse/tracks.csv");

/// The ECLES example problems of `examples/` (name, JSON text), solved by `trimorph demo`:
/// four pumps with `p0 + p1 = p2`, `p3 = p2 + 5` (set `p0 = 4`); the rank-3 system of
/// thesis 8.3 / 9.2 with two redundant rows; and dragging one corner of a parallelogram
/// (thesis fig. 2.1).
pub const ECLES_EXAMPLES: [(&str, &str); 3] = [
    ("pump", include_str!("../examples/pump.json")),
    ("thesis_8_3", include_str!("../examples/thesis_8_3.json")),
    ("parallelogram_2d", include_str!("../examples/parallelogram_2d.json")),
];

/// Errors building the bundled data (none occur for the data as shipped; each is kept with
/// its cause rather than hidden).
#[derive(Debug, thiserror::Error)]
pub enum BundledError {
    /// The mesh.
    #[error("bundled scene mesh: {0}")]
    Mesh(#[from] MeshError),
    /// The spline.
    #[error("bundled scene spline: {0}")]
    Spline(#[from] SplineError),
    /// The prism layers.
    #[error("bundled scene layers: {0}")]
    Prism(#[from] PrismError),
    /// Decoding a bundled image.
    #[error("bundled frame: {0}")]
    Image(#[from] image::ImageError),
    /// A malformed line of [`TIMELAPSE_TRACKS`] (1-based).
    #[error("bundled tracks.csv line {0}: expected track_id,frame,y,x")]
    Tracks(usize),
}

/// The bundled scene: the deformation (degree 5, identity, with z layers), the organism
/// model (placed across the frame) and time-lapse frame 0.
pub fn scene() -> Result<(Spline, Model, DynamicImage), BundledError> {
    let mut model =
        worm(&WormOptions { length: 380.0, radius: 14.0, bend: 35.0, rings: 120, around: 24 });
    for v in model.vertices.iter_mut() {
        v[0] += 65.0;
        v[1] += 250.0;
    }
    let mesh = Mesh::grid(8, 8, 511.0, 511.0, MeshOptions::default())?;
    let mut s = Spline::identity(mesh, 5)?;
    let z = identity_layers(&s, rat_int(-16), rat_int(16))?;
    s.set_z_layers(Some(z));
    let frame = image::load_from_memory(TIMELAPSE_FRAMES[0])?;
    Ok((s, model, frame))
}

/// The tracked positions `[x, y]` by `(track id, frame)`.
pub fn track_positions() -> Result<BTreeMap<(u32, u32), [f64; 2]>, BundledError> {
    let mut pos = BTreeMap::new();
    for (i, line) in TIMELAPSE_TRACKS.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let parse = || -> Option<(u32, u32, f64, f64)> {
            Some((
                f.first()?.parse().ok()?,
                f.get(1)?.parse().ok()?,
                f.get(2)?.parse().ok()?,
                f.get(3)?.parse().ok()?,
            ))
        };
        let (id, frame, y, x) = parse().ok_or(BundledError::Tracks(i + 1))?;
        pos.insert((id, frame), [x, y]);
    }
    Ok(pos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scene_is_an_identity_with_layers_over_frame_0() {
        let (s, model, frame) = scene().unwrap();
        assert_eq!((frame.width(), frame.height()), (511, 511));
        assert_eq!(s.num_points(), 1681);
        assert!(s.z_layers().is_some());
        s.check_c1().unwrap();
        assert!(!model.triangles.is_empty());
    }

    #[test]
    fn every_track_starts_in_frame_0_and_stays_in_the_frame() {
        let pos = track_positions().unwrap();
        assert!(!pos.is_empty());
        for (&(id, _), p) in &pos {
            assert!(pos.contains_key(&(id, 0)), "track {id} has no frame 0");
            assert!(p.iter().all(|c| (0.0..511.0).contains(c)), "{p:?}");
        }
    }
}
