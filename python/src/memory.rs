//! The library's memory budget ([`trimorph::memory`]) from Python.

use pyo3::prelude::*;

/// `trimorph.set_max_memory(size=None)`: the process's memory budget for large buffers, as
/// a number of bytes or a text such as `"4G"` or `"512M"`; `None` restores the default
/// (`TRIMORPH_MAX_MEMORY`, else half of the memory the process may use). Inputs whose
/// decoding would exceed it raise `MemoryError` before anything large is allocated.
#[pyfunction]
#[pyo3(signature = (size=None))]
pub fn set_max_memory(size: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
    let bytes = match size {
        None => None,
        Some(v) => Some(match v.extract::<u64>() {
            Ok(n) if n >= 1 << 20 => n,
            Ok(n) => {
                return Err(crate::errors::value_error(format!(
                    "max memory {n} bytes: at least 1 MiB (1048576)"
                )))
            }
            Err(_) => {
                let text: String = v.extract()?;
                trimorph::memory::parse_size(&text).map_err(crate::errors::value_error)?
            }
        }),
    };
    trimorph::memory::set_limit(bytes);
    Ok(())
}

/// `trimorph.max_memory()`: the process's memory budget in bytes.
#[pyfunction]
pub fn max_memory() -> u64 {
    trimorph::memory::limit()
}
