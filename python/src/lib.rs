//! Python bindings of trimorph: `import trimorph`.
//!
//! A thin layer over the library: every function here converts its arguments, releases the
//! GIL around the library call it wraps ([`pyo3::Python::detach`]) and converts the result.
//! No algorithm lives here, so what Python computes is what `trimorph` on the command line
//! computes (the tests in `python/tests` check the bit-identity of warps).
//!
//! Errors: bad input raises `ValueError` (with the library's message), missing or unreadable
//! files `OSError`, and edits or fits that cannot be solved [`errors::UnsolvableError`]
//! (a subclass of `trimorph.TrimorphError`) carrying the typed error's kind and message.

// Python functions take their options as keyword arguments, one Rust parameter each.
#![allow(clippy::too_many_arguments)]

use pyo3::prelude::*;

mod arrays;
mod axes;
mod deformation;
mod errors;
mod fitting;
mod memory;
mod registration;
mod sequence;
mod tiles;
mod values;
mod watch;

/// The extension's own large buffers (warp outputs, maps) on transparent huge pages, as in
/// the `trimorph` binary ([`trimorph::alloc`]); numpy's arrays keep Python's allocator.
#[global_allocator]
static ALLOC: trimorph::alloc::HugePages = trimorph::alloc::HugePages;

/// The native module `trimorph._trimorph` (re-exported by the `trimorph` package).
#[pymodule]
fn _trimorph(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<deformation::Deformation>()?;
    m.add_class::<sequence::FrameSequence>()?;
    m.add_class::<watch::CancelToken>()?;
    m.add_function(wrap_pyfunction!(fitting::fit, m)?)?;
    m.add_function(wrap_pyfunction!(fitting::morph, m)?)?;
    m.add_function(wrap_pyfunction!(registration::register, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::read_image, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::read_ome_zarr, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::tile_inputs, m)?)?;
    m.add_function(wrap_pyfunction!(tiles::warp_tile, m)?)?;
    m.add_function(wrap_pyfunction!(axes::image_axes, m)?)?;
    m.add_function(wrap_pyfunction!(memory::set_max_memory, m)?)?;
    m.add_function(wrap_pyfunction!(memory::max_memory, m)?)?;
    m.add("TrimorphError", m.py().get_type::<errors::TrimorphError>())?;
    m.add("UnsolvableError", m.py().get_type::<errors::UnsolvableError>())?;
    m.add("Cancelled", m.py().get_type::<watch::Cancelled>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
