//! `trimorph::server`: the editor in a headless browser ([`editor_e2e`]).

mod editor_e2e;
