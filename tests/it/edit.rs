//! `trimorph::edit`: select-all edits ([`select`]).

mod select;
