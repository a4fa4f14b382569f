//! `trimorph::fit`: quality on real images ([`real`]), target registration error
//! ([`tre`]) and many landmarks ([`scale`]).

mod real;
mod scale;
mod tre;
