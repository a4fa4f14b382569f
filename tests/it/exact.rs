//! `trimorph::exact`: the modular solve paths ([`modular`]).

mod modular;
