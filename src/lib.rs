//! # trimorph
//!
//! Smooth (C1), local, exactly constrained and hand-editable deformations for image
//! registration and morphing.
//!
//! Modules follow the data flow; lower modules never import higher ones (the floors are in
//! `docs/architecture.md`, checked by a test):
//!
//! * [`alloc`]: a global allocator asking for huge pages on large buffers (used by the
//!   binary; imports nothing of the crate);
//! * [`geom`]: points and vectors of the plane (pixels), the types of the public API;
//! * [`json`]: strict JSON reading (duplicate keys refused), used by every reader;
//! * [`timing`]: wall-time phases of a job (below every other module);
//! * [`rng`]: the seeded random generator behind every random draw the library reports
//!   (below every other module);
//! * [`memory`]: the process's memory budget, checked before large buffers are allocated
//!   (below every other module);
//! * [`sparse`]: sparse symmetric positive definite systems (faer's supernodal Cholesky),
//!   in `f64`, for the fit and the editor's select-all solve (below every other module);
//! * [`exact`]: exact integer / rational linear algebra (fraction-free LDU, exact solve,
//!   weighted least squares) -- thesis Part I, ch. 4 and 6-9;
//! * [`ecles`]: editing parameters under affine constraints (ECLES) -- thesis ch. 2 and 5;
//! * [`mesh`], [`spline`], [`edit`]: 2DSD spline deformations and their editing -- thesis
//!   Part II ([`edit::script`]: edit scripts as typed operations);
//! * [`warp`]: points and images through a deformation (forward and inverse);
//! * [`prism`]: 2.5D deformations of 3D models in a layer of prisms (PrisMystic);
//! * [`bundled`]: the data compiled in (microscope image, time-lapse, the bundled scene);
//! * [`fit`]: deformations fitted to matched landmarks (squares or robust losses, the fold
//!   barrier's Newton method on argmin, exact landmarks through ECLES);
//! * [`register`]: registration from the images themselves (intensity metrics, argmin's
//!   L-BFGS, landmarks and exact constraints in the same solve);
//! * [`io`]: every file format, read with limits and written atomically;
//! * [`render`]: pictures only (plots, deformations, models, colored meshes, overlays);
//! * [`morph`]: image morphing through two fitted deformations blended exactly;
//! * [`jobs`]: file jobs, the library calls behind the subcommands (read, compute, write
//!   atomically, report; no printing);
//! * [`server`]: the interactive editor (local HTTP server and embedded page);
//! * [`cli`]: the `trimorph` command line.
//!
//! "The thesis" in these docs is *Mathematical and computational methods for modeling and
//! editing deformations* (2017); "the ECLeS paper" is its 2015 conference version.

// Index loops are the clearest way to write the matrix algorithms here.
#![allow(clippy::needless_range_loop)]
#![warn(missing_docs)]

pub mod alloc;
pub mod bundled;
pub mod cancel;
pub mod cli;
pub mod ecles;
pub mod edit;
pub mod exact;
pub mod fit;
pub mod geom;
pub mod io;
pub mod jobs;
pub mod json;
#[cfg(test)]
mod layers;
pub mod memory;
pub mod mesh;
pub mod morph;
pub mod prism;
pub mod register;
pub mod render;
pub mod rng;
pub mod server;
pub mod sparse;
pub mod spline;
pub mod timing;
pub mod warp;
