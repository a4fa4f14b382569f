//! The `trimorph` command line through the binary: each subcommand (`*_cmd`, `solve`,
//! `spline_cmds`, `det_j`), the reference pages (`reference`), and the contracts every
//! command keeps: bad inputs ([`bad_inputs`]), no clobbering ([`no_clobber`]), no panics
//! ([`no_panics`]), nothing lost when killed ([`nothing_lost`]).

mod bad_inputs;
mod det_j;
mod editor_cmd;
mod fit_cmd;
mod match_cmd;
mod model_cmd;
mod morph_cmd;
mod no_clobber;
mod no_panics;
mod nothing_lost;
mod reference;
mod register_cmd;
mod register_frames;
mod solve;
mod spline_cmds;
mod warp_cmd;
