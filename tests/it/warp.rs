//! `trimorph::warp`: colored meshes ([`colormesh`]), golden images ([`golden`]) and
//! general maps ([`map2`]).

mod colormesh;
mod golden;
mod map2;
