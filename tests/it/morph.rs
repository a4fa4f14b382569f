//! `trimorph::morph`: the face pair ([`faces`]) and the real microscopy pair ([`real`]).

mod faces;
mod real;
