//! Library errors as Python exceptions.
//!
//! * input the library refuses (a malformed file, a landmark outside the mesh, an unknown
//!   option): `ValueError`, with the library's message (which names the file and element);
//! * files that cannot be read or written: `OSError` (`FileNotFoundError` when missing);
//! * edits and hard fits with no solution: `trimorph.UnsolvableError`, a subclass of
//!   `trimorph.TrimorphError`, whose `kind` attribute names the typed error's variant;
//! * anything else the library reports (an internal invariant): `trimorph.TrimorphError`.

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyFileNotFoundError, PyOSError, PyValueError};
use pyo3::prelude::*;
use trimorph::io::IoError;

create_exception!(
    trimorph,
    TrimorphError,
    PyException,
    "Base class of the errors trimorph raises besides ValueError and OSError."
);
create_exception!(
    trimorph,
    UnsolvableError,
    TrimorphError,
    "An edit or a hard fit with no solution; `kind` names the library's error variant."
);

/// `ValueError(message)`.
pub fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// `UnsolvableError(message)` with `kind` set.
pub fn unsolvable(py: Python<'_>, kind: &str, e: impl std::fmt::Display) -> PyErr {
    let err = UnsolvableError::new_err(e.to_string());
    // Setting an attribute on a fresh exception instance cannot fail in practice; if it
    // did, the exception without `kind` is still the right one to raise.
    let _ = err.value(py).setattr("kind", kind);
    err
}

/// An I/O error as `OSError` / `FileNotFoundError`.
pub fn io_error(e: &IoError) -> PyErr {
    let (IoError::Read { source, .. } | IoError::Write { source, .. }) = e;
    if source.kind() == std::io::ErrorKind::NotFound {
        PyFileNotFoundError::new_err(e.to_string())
    } else {
        PyOSError::new_err(e.to_string())
    }
}

/// The variant name of a `Debug`-printed enum value (`Conflicting { .. }` -> `Conflicting`).
pub fn variant_name(e: &impl std::fmt::Debug) -> String {
    let d = format!("{e:?}");
    d.split(|c: char| !c.is_alphanumeric() && c != '_').next().unwrap_or("").to_string()
}
